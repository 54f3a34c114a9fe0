#!/usr/bin/env bash
# On the lent GPU machine: install the carried wheels (.whl/) into /tmp/site and put the
# repository on the path. Usage: source scripts/gpu_setup.sh
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
  --target /tmp/site .whl/*.whl || return 1
export PYTHONPATH=/tmp/site:$PWD PYTHONUNBUFFERED=1
python3 -c "import jax, mujoco; print('jax', jax.__version__, jax.devices(), 'mujoco', mujoco.__version__)"
# The rl extra (docs/learning.md: scripts/train_policy.py, policy:DIR) needs these wheels in
# .whl/ beyond the image's jax, flax, optax, orbax: brax, gymnasium, jaxopt, ml_collections,
# farama_notifications, cloudpickle (pip download --no-deps -d .whl NAME==VERSION).
python3 -c "import brax, gymnasium; print('brax', brax.__version__, 'gymnasium', gymnasium.__version__)" \
  2>/dev/null | grep -v warp || echo "gpu_setup: no brax / gymnasium wheels in .whl/ (rl extra)"
