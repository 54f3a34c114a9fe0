"""Bundled scenario files, shipped inside the package as ``mjx_radar.scenarios``.

Load one by name with ``mjx_radar.load_scenario("smoke")``; list them with
``mjx_radar.bundled_scenarios()``. Every field is documented in docs/scenarios.md.
"""
