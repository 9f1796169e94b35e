"""Benchmark runner: drive baselines and SB3 agents through env configurations; metrics, tables and plots (``python -m eval``)."""
