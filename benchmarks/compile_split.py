"""Runs ``python -m mjx_radar ARGS`` in this process and prints, at exit, the seconds of
JAX's compile stages (tracing, lowering, XLA's backend compile) summed over the programs
it compiled (``jax.monitoring`` duration events). Used by ``bench_refactor.sh``::

    python benchmarks/compile_split.py run scenarios/smoke.toml --out DIR --force
"""

import atexit
import collections
import runpy
import sys

import jax.monitoring as m

dur = collections.defaultdict(float)
cnt = collections.Counter()


def listen(name, secs, **kw):
    dur[name] += secs
    cnt[name] += 1


m.register_event_duration_secs_listener(listen)


@atexit.register
def report():
    keys = [k for k in dur if "compile" in k or "trace" in k or "lower" in k or "mlir" in k]
    print("SPLIT " + " ".join(f"{k.split('/')[-1]}={dur[k]:.2f}s/{cnt[k]}" for k in sorted(keys)))


sys.argv = ["mjx_radar", *sys.argv[1:]]
runpy.run_module("mjx_radar", run_name="__main__")
