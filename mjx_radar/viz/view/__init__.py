"""The offline 3-D viewer (``mjx-radar view``): the figure, its traces, world, line of sight,
legend, controls, counts and budget."""
