#!/usr/bin/env python3
"""Renders drive-sim HTML reports in headless Chromium and checks what a reader would see.

    python3 tests/render_report.py REPORT.html [REPORT.html ...] [--screenshots DIR]

For each report: a screenshot of the first screen (1400 x 1000, written as
<DIR>/<parent dir name>.png, default beside the report), and, from the DOM after load, no
JavaScript error, no broken image, every figure non-empty and with a caption, nothing wider
than the window, and a first section with a heading. Exits 1 naming each problem; exits 2
when Chromium is missing (a check that cannot run must not pass).
Standard library only; needs `chromium` (Debian package `chromium`) on PATH or in $CHROMIUM.
"""

import html
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile

WIDTH, HEIGHT = 1400, 1000

# Injected first in <head>: records errors (scripts, and resources failing to load).
PROBE_HEAD = """<script>
window.__renderErrors = [];
window.addEventListener('error', function (e) {
  var t = e.target;
  window.__renderErrors.push(t && t !== window ? 'failed to load ' + (t.src || t.href || t.tagName) : String(e.message));
}, true);
</script>"""

# Injected last in <body>: measures the page once it has loaded.
PROBE_BODY = """<script>
window.addEventListener('load', function () {
  var figs = Array.prototype.slice.call(document.querySelectorAll('figure'));
  var imgs = Array.prototype.slice.call(document.images);
  var res = {
    errors: window.__renderErrors,
    broken_images: imgs.filter(function (i) { return !i.complete || i.naturalWidth === 0; }).map(function (i) { return i.src; }),
    figures: figs.length,
    empty_figures: figs.filter(function (f) {
      var s = f.querySelector('svg, img');
      if (!s) return true;
      var r = s.getBoundingClientRect();
      return !(r.width > 50 && r.height > 50);
    }).length,
    uncaptioned: figs.filter(function (f) {
      var c = f.querySelector('figcaption');
      return !c || c.textContent.trim().length < 10;
    }).length,
    page_width: document.documentElement.scrollWidth,
    first_heading: (document.querySelector('section h2') || {textContent: ''}).textContent
  };
  var pre = document.createElement('pre');
  pre.id = 'render-check';
  pre.textContent = JSON.stringify(res);
  document.body.appendChild(pre);
});
</script>"""


def chromium():
    exe = os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    if not exe:
        print("render_report.py: chromium not found (apt-get install -y chromium, or set $CHROMIUM)", file=sys.stderr)
        sys.exit(2)
    return exe


def run(exe, args, timeout=120):
    base = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
            "--disable-dev-shm-usage", "--no-first-run", "--virtual-time-budget=15000",
            "--enable-logging=stderr", "--v=0"]
    return subprocess.run(base + args, capture_output=True, text=True, timeout=timeout)


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return struct.unpack(">II", head[16:24])


def check(exe, report, shots):
    problems = []
    with open(report, encoding="utf-8") as f:
        text = f.read()
    if "<head>" not in text or "</body>" not in text:
        return [f"{report}: not an HTML document with <head> and </body>"]
    probed = text.replace("<head>", "<head>\n" + PROBE_HEAD, 1).replace("</body>", PROBE_BODY + "\n</body>", 1)
    with tempfile.TemporaryDirectory() as tmp:
        page = os.path.join(tmp, "probe.html")
        with open(page, "w", encoding="utf-8") as f:
            f.write(probed)
        dom = run(exe, ["--window-size=%d,%d" % (WIDTH, HEIGHT), "--dump-dom", "file://" + page])
    m = re.search(r'<pre id="render-check">(.*?)</pre>', dom.stdout, re.S)
    if dom.returncode != 0 or not m:
        return [f"{report}: Chromium did not render it (exit {dom.returncode}): {dom.stderr[-2000:]}"]
    res = json.loads(html.unescape(m.group(1)))
    console = [l for l in dom.stderr.splitlines() if "CONSOLE" in l and ("Uncaught" in l or "rror" in l)]
    for e in res["errors"] + console:
        problems.append(f"{report}: error: {e}")
    for src in res["broken_images"]:
        problems.append(f"{report}: broken image {src}")
    if res["figures"] == 0:
        problems.append(f"{report}: no figure")
    if res["empty_figures"]:
        problems.append(f"{report}: {res['empty_figures']} figures render empty")
    if res["uncaptioned"]:
        problems.append(f"{report}: {res['uncaptioned']} figures without a caption")
    if res["page_width"] > WIDTH + 2:
        problems.append(f"{report}: page {res['page_width']} px wide in a {WIDTH} px window")
    if not res["first_heading"].strip():
        problems.append(f"{report}: the first section has no heading")

    os.makedirs(shots, exist_ok=True)
    name = os.path.basename(os.path.dirname(os.path.abspath(report))) or "report"
    shot = os.path.join(os.path.abspath(shots), name + ".png")
    if os.path.exists(shot):
        os.remove(shot)
    s = run(exe, ["--window-size=%d,%d" % (WIDTH, HEIGHT), "--screenshot=" + shot, "file://" + os.path.abspath(report)])
    size = png_size(shot) if os.path.exists(shot) else None
    if s.returncode != 0 or size != (WIDTH, HEIGHT):
        problems.append(f"{report}: no {WIDTH}x{HEIGHT} screenshot (exit {s.returncode}, got {size})")
    elif os.path.getsize(shot) < 20000:
        problems.append(f"{report}: the first screen looks blank ({os.path.getsize(shot)} bytes of PNG)")
    print(f"{report}: {res['figures']} figures, first section `{res['first_heading']}`, screenshot {shot}")
    return problems


def main(argv):
    shots = None
    reports = []
    i = 0
    while i < len(argv):
        if argv[i] == "--screenshots":
            shots = argv[i + 1]
            i += 2
        else:
            reports.append(argv[i])
            i += 1
    if not reports:
        print(__doc__, file=sys.stderr)
        return 2
    exe = chromium()
    problems = []
    for r in reports:
        if not os.path.isfile(r):
            problems.append(f"{r}: no such file")
            continue
        problems += check(exe, r, shots or os.path.dirname(os.path.abspath(r)))
    for p in problems:
        print("PROBLEM " + p, file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
