"""The numerical engine, which knows nothing of mechanisms: the compiled adaptive
Runge-Kutta integrator with event location (`integrator`), the numba options of
every kernel (`_kernel`) and a fused sine-cosine (`_trig`)."""
