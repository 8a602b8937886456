"""The discrepancy diagnosis: forward model of a campaign's observables, null model, candidate
effects, fits and verdict."""
