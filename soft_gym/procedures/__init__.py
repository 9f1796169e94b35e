"""Procedures that drive a private simulator of the arm: above the estimators and the tasks.

A real robot's estimators and tasks never hold the physics; the set-up work that does (a
calibration's exploration, a data set, the reachable workspace, driving the tip to an episode's
start) lives here, and hands its results down:

| module                  | what it drives                                                      |
|-------------------------|---------------------------------------------------------------------|
| `calibration`           | every calibrating feedback source's procedure, by name              |
| `workspace`             | the reachable tips (reach targets, track paths)                     |
| `positioning`           | the tip driven to an episode's start (point to point)               |

Each paper's own procedures (wang2023's spiral exploration, zhao2021's exploration and arm fit,
zou2022's ASES-labelled data set) live in its folder, ``soft_gym/papers/<key>/``, and join
``calibration.CALIBRATIONS`` when the paper is registered.
"""
