"""Baseline controllers: cc_model and hybrid_gpr (wang2023)."""
