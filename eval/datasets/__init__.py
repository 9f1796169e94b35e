"""Offline data as Minari datasets: the papers' exploration and calibration data, and the
suite's runs.

* :mod:`eval.datasets.papers`: each paper's data collection as a dataset
  (:data:`PAPER_DATASETS`; ``python -m eval datasets``).
* :mod:`eval.datasets.suite`: a suite's runs as one dataset per arm and condition
  (``python -m eval suite SPEC --record minari``).
* :mod:`soft_gym.datasets.episodes`: episodes from env runs (``EpisodeRecorder``) and from
  procedures' samples, which the papers' and the suite's datasets are written from.
* :mod:`soft_gym.datasets.store`: writing (never over an existing dataset without ``force``) and
  loading with checks (:func:`load_dataset`: one ``ValueError`` for an unknown id, a corrupt or
  truncated directory, a data file whose SHA-256 digest differs from the one recorded when it
  was written, or another env version).
* :mod:`eval.datasets.cards`: the data card written next to each dataset.
* :mod:`soft_gym.datasets.training`: a paper's dataset read back as the data its method trains on
  (``local_ik_asdm``, ``strain_sr``, ``encoder_dnn``, ``lwpr_rwr``; ``dataset=<id>``), checked
  against the method's settings.

The ids, fields and units and the data cards are in docs/datasets.md.
"""

from eval.datasets.papers import PAPER_DATASETS, Collection, PaperDataset
from soft_gym.datasets.store import (default_root, list_datasets, load_dataset, recover_env,
                                     write_dataset)
from eval.datasets.write import write_paper_dataset

__all__ = ["PAPER_DATASETS", "Collection", "PaperDataset", "default_root", "list_datasets",
           "load_dataset", "recover_env", "write_dataset", "write_paper_dataset"]
