"""The live view's page (:mod:`mjx_radar.viz.live_view.live_page` serves it, docs/viewer.md).

It loads plotly.js from the live server (``/plotly.min.js``), the figure once
(``/figure.json``), then polls ``/state.json`` every 250 ms. Opened at any time, it first
replays the run from its start (``/state.json?step=K``, one segment per poll), then follows
the latest state ("live" ticked); the step slider goes back to any step received (and
unticks "live"). ``window.liveState`` (seq, step, the steps shown, the mode) is for tests.
"""

from __future__ import annotations

PAGE = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>mjx-radar live: {name}</title>
<link rel="icon" href="data:,">
<script src="plotly.min.js"></script>
<style>body {{font-family: sans-serif; margin: 6px}} #status {{margin-left: 1em}}</style>
</head><body>
<label>trial <select id="trial">{options}</select></label>
<label> step <input id="step" type="range" min="1" max="1" value="1" style="width: 40%"></label>
<label><input id="live" type="checkbox"> live</label><span id="status">waiting for the
first segment (compiling)...</span>
<div id="plot" style="height: 92vh"></div>
<script>
var gd = document.getElementById('plot'), statusEl = document.getElementById('status');
var seq = -1, trial = 0, ranges = null, ends = [], want = null, shown = 0;
var slider = document.getElementById('step'), liveBox = document.getElementById('live');
// replay: from the run's start, one segment per poll, then live: the latest state;
// scrub: the step the slider was moved to
var mode = 'replay';
window.liveState = {{seq: -1, step: 0, finished: false, ended: false, shown: [], mode: mode}};
document.getElementById('trial').onchange = function (e) {{
  trial = Number(e.target.value); seq = -1;
  if (mode === 'scrub') {{ want = shown; }}
}};
slider.oninput = function () {{
  mode = 'scrub'; want = Number(slider.value); liveBox.checked = false;
}};
liveBox.onchange = function () {{
  if (liveBox.checked) {{ mode = 'live'; seq = -1; }} else {{ mode = 'scrub'; want = shown; }}
}};
function sleep(ms) {{ return new Promise(function (r) {{ setTimeout(r, ms); }}); }}
function apply(s) {{  // one Plotly.react: one redraw of the scene per state
  var d = gd.data, lay = gd.layout;
  s.anim.forEach(function (i, n) {{
    d[i] = Object.assign({{}}, d[i], {{x: s.layers[n].x, y: s.layers[n].y, z: s.layers[n].z}});
  }});
  var w = s.anim[6];
  d[w] = Object.assign({{}}, d[w], {{line: Object.assign({{}}, d[w].line, {{color: s.sample_w}})}});
  var xs = [s.time, s.time, [s.t, s.t]], ys = [s.rmse, s.crlb, s.now];
  s.counts.forEach(function (c) {{ xs.push(s.time); ys.push(c); }});
  if (s.counts.length) {{
    xs.push(s.counts.map(function () {{ return s.t; }})); ys.push(s.counts_now);
  }}
  s.metrics.forEach(function (i, n) {{
    d[i] = Object.assign({{}}, d[i], {{x: xs[n], y: ys[n]}});
  }});
  var r = JSON.stringify(s.ranges);
  if (r !== ranges) {{
    ranges = r;
    d[0] = Object.assign({{}}, d[0], {{x: s.ground[0], y: s.ground[1], z: s.ground[2]}});
    var sc = Object.assign({{}}, lay.scene);
    ['xaxis', 'yaxis', 'zaxis'].forEach(function (a, n) {{
      sc[a] = Object.assign({{}}, sc[a], {{range: s.ranges[n]}});
    }});
    lay = Object.assign({{}}, lay, {{scene: sc}});
  }}
  return Plotly.react(gd, d.slice(), lay);
}}
async function run() {{
  for (;;) {{
    try {{
      var f = await (await fetch('figure.json')).json();
      if (f.ready) {{
        await Plotly.newPlot(gd, f.data, f.layout, {{displaylogo: false}});
        break;
      }}
    }} catch (e) {{ statusEl.textContent = 'no server: the run has ended'; return; }}
    await sleep(500);
  }}
  for (;;) {{
    var s, url = null;
    if (mode === 'live') {{
      url = 'state.json?trial=' + trial + '&since=' + seq;
    }} else if (mode === 'replay') {{
      var next = ends.filter(function (e) {{ return e > shown; }})[0];
      url = 'state.json?trial=' + trial + '&step=' + (next || 1);
    }} else if (want !== null) {{
      url = 'state.json?trial=' + trial + '&step=' + want; want = null;
    }}
    if (url !== null) {{
      try {{
        s = await (await fetch(url)).json();
      }} catch (e) {{
        statusEl.textContent = 'the run has ended and its server stopped: this is its last state';
        window.liveState.ended = true;
        return;
      }}
      ends = s.ends || ends;
      if (s.layers && (mode !== 'live' || s.seq !== seq)) {{
        await apply(s);
        seq = s.seq; shown = s.step;
        slider.max = ends[ends.length - 1]; slider.value = s.step;
        if (mode === 'replay' && s.step >= ends[ends.length - 1]) {{
          mode = 'live'; liveBox.checked = true;
        }}
        var st = window.liveState;
        st.shown.push(s.step);
        window.liveState = {{seq: s.seq, step: s.step, finished: s.finished, ended: false,
                            trial: trial, shown: st.shown, mode: mode}};
        statusEl.textContent = 'step ' + s.step + ' of ' + s.steps + ' (t = ' +
          s.t.toFixed(2) + ' s)' + (mode === 'replay' ? ': replaying from the start' : '') +
          (s.finished ? ': run finished' : '');
      }}
    }}
    await sleep(250);
  }}
}}
run();
</script></body></html>
"""
