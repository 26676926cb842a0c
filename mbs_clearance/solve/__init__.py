"""Running a generated model: the runs of a linkage (`linkage_model`) and of the
paper's parameter set (`reduced`), their DDM sensitivities (`linkage_ddm`), the
public `simulate` with its backend registry, runs to a requested accuracy
(`accuracy`), contact diagnostics, window-by-window flows, and the result type
(`trajectory.Trajectory`)."""
