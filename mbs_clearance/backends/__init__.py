"""The other models of the same description: Exudyn (`exudyn_linkage`,
`exudyn_model`, its step refinement `exudyn_convergence`) and the ideal joints (`ideal`:
the paper's closed form; `ideal_linkage`: any description with its clearance joints
closed), with the body-frame kinematics they share (`kinematics`). `solve.simulate`'s
registry loads them by module path on demand."""
