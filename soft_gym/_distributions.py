"""Python distributions whose installed versions records and caches note, named by their role.

A distribution's name is what :func:`importlib.metadata.version` looks up. The reference engine's
equals the name the engine is registered under (:data:`soft_gym.engines.ENGINES`) but means the
package, not the engine: what an engine can do is asked by feature
(:func:`soft_gym.engines.engine_supports`). This module imports nothing, so that the calibration
cache, which never imports the engines (docs/architecture.md, "Layers and packages"), reads it too.
"""

REFERENCE_ENGINE_PACKAGE = "pybullet"
"""The distribution of the reference engine (:data:`soft_gym.engines.REFERENCE_ENGINE`), whose
version the calibration cache's keys, suite records, dataset cards and training runs note."""
