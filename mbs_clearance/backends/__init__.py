"""The other models of the same description: Exudyn (`exudyn_linkage`,
`exudyn_model`, its step refinement `exudyn_convergence`) and the ideal joint
(`ideal`). `solve.simulate`'s registry loads them by module path on demand."""
