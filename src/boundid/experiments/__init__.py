"""Layer 4, experiments: excitation, simulation, measurement, preprocessing, regressions."""
