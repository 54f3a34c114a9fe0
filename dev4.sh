source scripts/gpu_setup.sh > /tmp/setup.log 2>&1; python -m compileall -q mjx_radar > /dev/null
nvidia-smi --query-gpu=name --format=csv,noheader
python scripts/bench_compile.py --out $OUT/two --cases paper --variants staged --paper-trials 500 2>&1 | grep '^{'
CUDA_VISIBLE_DEVICES=0 python scripts/bench_compile.py --out $OUT/one --cases paper --variants staged --paper-trials 500 2>&1 | grep '^{'
for d in two one; do python -c "
import json; m=json.load(open('$OUT/$d/res-paper-staged-cold/study.json'))
print('$d', m['n_devices'], 'compile', round(m['compile_s'],1), 'sim', round(m['sim_s'],1), 'wall', round(m['wall_s'],1))
for p in m['programs']: print({k: p.get(k) for k in ('scenario','devices','source','trace_lower_s','xla_compile_s')})
"; done
cd $OUT && tar czf studies.tgz one/compile.csv two/compile.csv one/res-*/study.json two/res-*/study.json && rm -rf one two
