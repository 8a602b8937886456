"""Tests of the diagnosis's model: observables, tone and gate models, the null model and its learnt nuisances."""
