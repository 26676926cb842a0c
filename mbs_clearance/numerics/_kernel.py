"""The numba options of every compiled kernel (the integrator's, the generated models' and
the contact and friction laws'), in a module of its own so that the laws need not import
the solver."""

#: numba options of the kernels (model functions and the integrator's helpers, everything
#: that runs per stage or per step and allocates nothing): error_model="numpy" drops the
#: zero-division checks of every float division (the kernels guard their divisors), and
#: without numba's runtime (_nrt=False) passing arrays to a compiled function costs no
#: atomic reference counting (it was 22 % of a simulation, measured with perf). Such
#: functions cannot allocate arrays; `integrate` itself allocates and keeps the runtime.
KERNEL = {"cache": True, "error_model": "numpy", "_nrt": False}
