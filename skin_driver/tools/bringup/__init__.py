"""
The bring-up kit: one command a person runs once with a new board on its port.

- analysis: pure functions on count stacks (noise, dead/stuck/shorted, orientation, ghosting,
  the clock fit);
- reader: the board's frames through the driver's link and decoder, windows of device time;
- report: report.md with PNG heatmaps, summary.json and a dataset (docs/dataset.md);
- cli: the steps and their prompts (``python -m skin_driver.tools.bringup``).
"""
