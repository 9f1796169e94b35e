"""System identification: an arm fitted to a log of a real arm's commands and tip positions
(docs/architecture.md, "Fit the arm to your data").

``log.py`` reads and checks the CSV log, ``replay.py`` simulates its commands, ``parameters.py``
names what may be fitted, ``fit.py`` fits it, ``report.py`` writes the result, ``synthetic.py``
makes logs from a known arm.
"""

from soft_gym.identify.fit import FitResult, FittedParameter, fit_arm
from soft_gym.identify.log import ArmLog, check_log, read_log, write_log
from soft_gym.identify.parameters import Parameter, default_parameters, parse_parameters

__all__ = ["ArmLog", "FitResult", "FittedParameter", "Parameter", "check_log",
           "default_parameters", "fit_arm", "parse_parameters", "read_log", "write_log"]
