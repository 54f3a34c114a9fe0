"""A dataclass whose constructor also takes each field's TOML name (docs/scenarios.md).

``Scenario(targets=..., radars=..., radar_equation=...)`` is
``Scenario(target_init=..., radar_init=..., radar_eq=...)``: the names of the scenario
file work in Python as they do in :meth:`~mjx_radar.scenario.schema.Scenario.replace`.
"""

from __future__ import annotations

import dataclasses
import functools


def accept_toml_names(cls: type) -> type:
    """Wraps the dataclass ``cls``'s ``__init__`` so TOML names map to field names."""
    init = cls.__init__
    names = {f.metadata["toml"]: f.name for f in dataclasses.fields(cls) if "toml" in f.metadata}

    @functools.wraps(init)
    def __init__(self, *args, **kwargs):
        for toml, name in names.items():
            if toml in kwargs and toml != name:
                if name in kwargs:
                    raise TypeError(
                        f"{cls.__name__}() got both {name!r} and its TOML name {toml!r}"
                    )
                kwargs[name] = kwargs.pop(toml)
        init(self, *args, **kwargs)

    cls.__init__ = __init__
    return cls
