"""Learned placement policies (docs/learning.md): features, the brax and gymnasium
adapters of the environment, PPO training and the planner ``policy:DIR``.

Only :mod:`mjx_radar.learning.features` is importable without the ``rl`` extra
(``pip install -e ".[rl]"``: brax, gymnasium); the other modules import brax or
gymnasium.
"""
