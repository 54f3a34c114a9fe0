"""Checkpoints of a distillation: the whole training state as arrays, written atomically.

``DIR/checkpoints/<iteration:06d>/`` holds ``params.npz`` (the set network's parameters:
all the planner ``policy:DIR`` reads) and ``state.npz`` (parameters, Adam's state and
every replay buffer: what a resumed run needs to continue exactly where it stopped).
Both are the pytrees' leaves in order; reading them needs a template of the same
structure (a freshly initialised state of the same configuration).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import jax
import numpy as np

from mjx_radar.io.checks import ScenarioError


def _save_leaves(path: Path, tree) -> None:
    leaves = [np.asarray(x) for x in jax.tree.leaves(tree)]
    with path.open("wb") as f:
        np.savez(f, *leaves)


def load_leaves(path: Path, template):
    """``template``'s structure filled with the arrays of ``path`` (one line if they do
    not fit: another configuration or a damaged file)."""
    leaves, treedef = jax.tree.flatten(template)
    try:
        with np.load(path) as z:
            arrays = [z[f"arr_{i}"] for i in range(len(z.files))]
    except (OSError, ValueError, KeyError) as err:
        raise ScenarioError(f"checkpoint {path} cannot be read ({err})") from None
    shapes_ok = len(arrays) == len(leaves) and all(
        a.shape == np.shape(t) for a, t in zip(arrays, leaves, strict=False)
    )
    if not shapes_ok:
        raise ScenarioError(
            f"checkpoint {path} does not fit this configuration (damaged or edited)"
        )
    return jax.tree.unflatten(treedef, [jax.numpy.asarray(a) for a in arrays])


def save(out: Path, iteration: int, params, full_state) -> str:
    """Writes checkpoint ``iteration`` (to a temporary folder, then renamed) and removes
    the older ones; returns its path relative to ``out``."""
    root = out / "checkpoints"
    root.mkdir(parents=True, exist_ok=True)
    name = f"{iteration:06d}"
    tmp = root / f".{name}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    _save_leaves(tmp / "params.npz", params)
    _save_leaves(tmp / "state.npz", full_state)
    final = root / name
    shutil.rmtree(final, ignore_errors=True)
    tmp.rename(final)
    return f"checkpoints/{name}"


def prune(out: Path, keep: str) -> None:
    """Removes every checkpoint of ``out`` but ``keep`` (after ``policy.json`` names it)."""
    for old in (out / "checkpoints").glob("*"):
        if old.is_dir() and old.name != Path(keep).name:
            shutil.rmtree(old, ignore_errors=True)
