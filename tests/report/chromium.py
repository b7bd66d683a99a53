"""Open an HTML file in headless Chromium (Debian's `chromium`) and report which images decoded."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage"]
# Appended to a copy of the page: after load, record each image's decoded size, what each case section shows
# (a decoded, visible sketch and bird's-eye view; a contact table with rows) and every resource the page fetched.
PROBE = """<script>
window.addEventListener('load', () => {
  const shown = el => !!el && el.getBoundingClientRect().width > 0 && el.getBoundingClientRect().height > 0;
  const decoded = el => shown(el) && el.complete && el.naturalWidth > 0;
  const images = Array.from(document.images).map(i => ({alt: i.alt, ok: i.complete && i.naturalWidth > 0,
                                                       w: i.naturalWidth, h: i.naturalHeight}));
  const cases = Array.from(document.querySelectorAll('section.case')).map(s => ({
    id: s.id, sketch: decoded(s.querySelector('img.sketch')), view: decoded(s.querySelector('img.birdseye')),
    contacts: shown(s.querySelector('table.contacts')) ? s.querySelectorAll('table.contacts tr').length - 1 : -1}));
  const resources = performance.getEntriesByType('resource').map(e => e.name);
  const pre = document.createElement('pre'); pre.id = 'image-probe';
  pre.textContent = JSON.stringify({images: images, cases: cases, resources: resources});
  document.body.appendChild(pre);
});
</script>"""


def _run(args: list[str], profile: Path) -> subprocess.CompletedProcess:
    return subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", *args], capture_output=True, text=True,
                          timeout=120)


def probe(html: Path, work: Path) -> dict:
    """{images: [{alt, ok, w, h}], cases: [{id, sketch, view, contacts}], resources: [url]} of `html` as
    Chromium loaded it (offline, file://)."""
    probe = work / "probe.html"
    probe.write_text(html.read_text(encoding="utf-8").replace("</body>", PROBE + "</body>"), encoding="utf-8")
    done = _run(["--virtual-time-budget=10000", "--dump-dom", probe.as_uri()], work / "profile")
    match = re.search(r'<pre id="image-probe">(.*?)</pre>', done.stdout, re.S)
    assert match, f"no probe output from chromium: {done.stderr[-2000:]}"
    return json.loads(match.group(1).replace("&quot;", '"').replace("&amp;", "&"))


def screenshot(html: Path, png: Path, work: Path, size: str = "1280,2400") -> Path:
    _run([f"--screenshot={png}", f"--window-size={size}", "--hide-scrollbars", html.as_uri()], work / "profile-shot")
    return png
