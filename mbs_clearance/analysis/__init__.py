"""What a run means: sensitivities (`sensitivity`), objectives and the exact
gradient of a peak (`objective`), Poincare sections and the regime rule
(`poincare`), Lyapunov exponents (`lyapunov`), periodic orbits and their continuation
(`periodic`)."""
