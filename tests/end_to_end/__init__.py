"""Whole campaigns simulated, analysed and diagnosed, from the simulator to the reports."""
