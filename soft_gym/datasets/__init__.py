"""Minari datasets of the arms: reading, writing and checking them (:mod:`.store`; the digests of
their data files in :mod:`.digest`), episodes of env runs and of procedures' samples as Minari
takes them (:mod:`.episodes`: the ``EpisodeRecorder`` wrapper), and reading a paper's
exploration or calibration data back into the data object its method trains on
(:mod:`.training`). What collects the data and the ``python -m eval datasets`` command are in
:mod:`eval.datasets`; docs/datasets.md describes the datasets."""
