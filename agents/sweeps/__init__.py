"""Optuna sweeps over hyperparameters: the study, its storage, search spaces, objectives and
reports."""
