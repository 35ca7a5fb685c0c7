#include "flatscan/outputs/station_page.h"

namespace flatscan {
namespace {

// Every value is written with textContent (never as HTML): a source id or a reason from a
// file name cannot inject markup.
constexpr std::string_view kPage = R"html(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>flatscan station</title>
<style>
body{font-family:sans-serif;margin:20px;color:#222}h1{margin:0 0 8px 0;font-size:22px}
h2{font-size:16px;margin:18px 0 6px 0}.row{display:flex;gap:32px;align-items:flex-start;flex-wrap:wrap}
#verdict{font-size:88px;font-weight:bold;line-height:1}.pass{color:#080}.fail{color:#c00}.none{color:#888}
#state.not_ready{background:#c00;color:#fff;padding:2px 8px}#state.ready{background:#080;color:#fff;padding:2px 8px}
table{border-collapse:collapse}td,th{padding:3px 10px;text-align:left;border-bottom:1px solid #ddd;font-size:14px}
#bar{width:320px;height:14px;background:#eee;position:relative}#fill{height:14px;background:#1f5fa8}
#tol{position:absolute;top:-3px;width:2px;height:20px;background:#c00}.small{color:#666;font-size:13px}
</style></head>
<body>
<h1><span id="station">flatscan station</span> <span id="state"></span></h1>
<div class="small">recipe <span id="recipe">-</span> &middot; started <span id="started">-</span>
 &middot; <span id="rate">0</span> parts/min</div>
<div class="row"><div>
<div id="verdict" class="none">-</div>
<div id="part" class="small">no part yet</div>
<div id="bar"><div id="fill" style="width:0"></div><div id="tol"></div></div>
<div id="flatness" class="small"></div>
<img id="overlay" alt="" width="320" style="display:none;margin-top:8px"></div>
<div><h2>Counts</h2><table><tr><th></th><th>measured</th><th>pass</th><th>fail</th><th>marginal</th>
<th>not measured</th><th>yield</th></tr>
<tr id="c-store"><th>whole store</th><td></td><td></td><td></td><td></td><td></td><td></td></tr>
<tr id="c-shift"><th>shift</th><td></td><td></td><td></td><td></td><td></td><td></td></tr>
<tr id="c-start"><th>since start</th><td></td><td></td><td></td><td></td><td></td><td></td></tr></table></div></div>
<h2>Trend: the last flatness values (mm), individuals and moving-range charts, tolerance in red</h2>
<img id="trend" alt="trend" src="/api/trend.svg"><br><img id="mr" alt="moving range" src="/api/moving-range.svg">
<div class="row"><div><h2>Recent fails and not measured</h2>
<table id="problems"><tr><th>#</th><th>time (UTC)</th><th>part</th><th>verdict</th><th>why</th><th>image</th></tr>
</table></div>
<div><h2>Health</h2><table id="health"></table></div></div>
<script>
const $ = id => document.getElementById(id);
function cells(row, values) {
  const tds = $(row).querySelectorAll('td');
  values.forEach((v, i) => tds[i].textContent = v);
}
function counts(row, c) {
  const y = c.yield === null || c.yield === undefined ? '-' : (100 * c.yield).toFixed(1) + '%';
  cells(row, [c.measured, c.pass, c.fail, c.marginal, c.not_measured, y]);
}
function table(id, header, rows) {
  const t = $(id);
  while (t.rows.length > header) t.deleteRow(header);
  for (const r of rows) {
    const tr = t.insertRow();
    for (const v of r) tr.insertCell().textContent = v;
  }
}
// A calibration file by its hash's first 12 digits and its age; other values as JSON.
function healthText(key, value) {
  if (key === 'calibration')
    return value.map(c => c.recipe + ': rig ' + c.rig_sha256.slice(0, 12) + ' (' + c.rig_age_days + ' d), plane ' +
                          c.plane_sha256.slice(0, 12) + ' (' + c.plane_age_days + ' d)').join('; ');
  return typeof value === 'object' ? JSON.stringify(value) : value;
}
// A part's thumbnail: hidden when the station kept none (404).
function image(img, sequence) {
  img.onerror = () => { img.style.display = 'none'; };
  img.onload = () => { img.style.display = ''; };
  img.src = '/api/parts/' + Number(sequence) + '/image.jpg';
}
function problems(list) {
  const t = $('problems');
  while (t.rows.length > 1) t.deleteRow(1);
  for (const p of list) {
    const tr = t.insertRow();
    for (const v of [p.sequence, p.time_utc, p.source_id, p.verdict, p.reason]) tr.insertCell().textContent = v;
    const img = document.createElement('img');
    img.width = 120;
    image(img, p.sequence);
    tr.insertCell().appendChild(img);
  }
}
let shown = -1;
function show(s) {
  $('station').textContent = 'flatscan station ' + s.station_id;
  $('state').textContent = s.state === 'ready' ? 'ready' : 'NOT READY: ' + (s.not_ready_reason || '');
  $('state').className = s.state;
  $('started').textContent = s.started_utc;
  $('rate').textContent = s.rate_per_min;
  counts('c-store', Object.assign({yield: s.yield}, s.counts));
  counts('c-shift', s.shift.counts);
  $('c-shift').firstElementChild.textContent = 'shift ' + s.shift.name;
  counts('c-start', s.since_start);
  const h = s.health || {};
  if (h.active_recipe) $('recipe').textContent = h.active_recipe;
  table('health', 0, Object.keys(h).map(k => [k, healthText(k, h[k])]));
  if (!s.last || s.last.sequence === shown) return;
  shown = s.last.sequence;
  problems(s.recent_problems);
  image($('overlay'), s.last.sequence);
  const r = s.last, v = $('verdict');
  v.textContent = r.measured ? r.verdict.toUpperCase() + (r.marginal ? ' (marginal)' : '') : 'NOT MEASURED';
  v.className = r.measured ? r.verdict : 'none';
  $('part').textContent = '#' + r.sequence + ' ' + r.source_id + ' at ' + r.time_utc + ' (' + r.recipe + ')';
  if (r.measured) {
    const scale = 1.5 * r.tolerance_mm;
    $('fill').style.width = Math.min(100, 100 * r.flatness_mm / scale) + '%';
    $('tol').style.left = (100 / 1.5) + '%';
    $('flatness').textContent = 'flatness ' + r.flatness_mm.toFixed(4) + ' mm, tolerance ' +
        r.tolerance_mm.toFixed(3) + ' mm, coverage ' + (100 * r.coverage).toFixed(0) + '%';
  } else {
    $('fill').style.width = '0';
    $('flatness').textContent = r.error;
  }
  $('trend').src = '/api/trend.svg?after=' + r.sequence;
  $('mr').src = '/api/moving-range.svg?after=' + r.sequence;
}
function poll() {
  fetch('/api/summary').then(r => r.json()).then(show).catch(() => {}).finally(() => setTimeout(poll, 1000));
}
poll();
</script></body></html>
)html";

}  // namespace

std::string_view StationPageHtml() { return kPage; }

}  // namespace flatscan
