"""The papers' experiments, one module per paper (``python -m eval <paper>``): ``estimation``
(wang2023's estimation experiments), ``ho2018``, ``zhao2021``, and ``zou2022`` with its
closed-loop comparison in ``zou2022_control``."""
