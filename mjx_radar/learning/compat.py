"""brax 0.14 on jax 0.10: the one function brax's training needs that jax stopped exporting.

``brax.training.agents.ppo.train`` and ``brax.training.pmap`` call
``jax.device_put_replicated`` (replicate the training state over the local devices for
``pmap``). jax 0.10 removed that name from its namespace (``jax.__getattr__`` raises
``AttributeError``, "Removed for v0.10.0") but keeps the function itself,
``jax._src.api.device_put_replicated``, unchanged. :func:`ensure` puts jax's own function
back under its old name, once, before brax trains; nothing else of brax or jax is
changed, and nothing happens on a jax that still exports it.
"""

from __future__ import annotations


def ensure() -> None:
    """Makes ``jax.device_put_replicated`` resolve (jax's own implementation)."""
    import jax

    try:
        jax.device_put_replicated  # noqa: B018 -- a jax that still exports it
        return
    except AttributeError:
        pass
    from jax._src import api

    fn = getattr(api, "device_put_replicated", None)
    if fn is None:
        raise ImportError(
            f"brax's PPO needs jax.device_put_replicated, absent from jax {jax.__version__}"
        )
    jax.device_put_replicated = fn
