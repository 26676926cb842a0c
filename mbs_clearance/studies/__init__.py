"""Many runs: the genetic algorithm (`optimize`), tolerance studies (`tolerance`),
regime maps (`sweep`), on a local pool or dask (`executor`)."""
