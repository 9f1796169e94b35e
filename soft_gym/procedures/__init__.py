"""Procedures that drive a private simulator of the arm: above the estimators and the tasks.

A real robot's estimators and tasks never hold the physics; the set-up work that does (a
calibration's exploration, a data set, the reachable workspace, driving the tip to an episode's
start) lives here, and hands its results down:

| module                  | what it drives                                                      |
|-------------------------|---------------------------------------------------------------------|
| `calibration`           | every calibrating feedback source's procedure, by name              |
| `wang2023_calibration`  | the spiral exploration that calibrates the camera/F-emp pipeline    |
| `zhao2021_exploration`  | the random exploration and the SFE-PD networks trained on it        |
| `zou2022_dataset`       | the ASES-labelled data set and the shape DNN trained on it          |
| `workspace`             | the reachable tips (reach targets, track paths)                     |
| `positioning`           | the tip driven to an episode's start (point to point)               |
"""
