"""The main job: every analysis on a campaign folder, each calibration fitted once."""

__all__: list[str] = []
