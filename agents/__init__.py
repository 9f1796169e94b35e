"""Baseline estimators, controllers and online learners; they use soft_gym, never the reverse."""
