"""zhao2021 (Zhao et al. 2021): shape reconstruction from strain gauges: the exploration data
set and key points, the SFE-PD networks, the 3-D backbone fit; the ``strain_sr`` feedback
source."""
