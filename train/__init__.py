"""Training stable-baselines3 agents on the soft-arm envs (``python -m train --help``)."""
