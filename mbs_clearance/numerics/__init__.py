"""The numerical engine's Python side, which knows nothing of mechanisms: the integration
methods and run settings of the compiled integrator (`integrator`) and a fused sine-cosine
(`_trig`)."""
