"""report.html in a real browser (issue 15): headless Chromium, its network off, opens the page from disk and
decodes every embedded view. Skipped where no Chromium is installed (CI has none; here: Debian's
``chromium``). The structural check that the page loads no external resource is
tests/test_estimate_cli.py::test_report_html_is_self_contained_with_the_verdicts_and_four_views."""

from __future__ import annotations

import functools
import re
import shutil
import subprocess
import threading
from contextlib import contextmanager
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
import pytest
from fixtures.plant_records import plant_run

from oilwatch.cli import main
from oilwatch.records.writers import write_record

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)
PROBE = """<script>
window.addEventListener("load", () => {
  const sizes = [...document.images].map(i => `${i.complete}:${i.naturalWidth}x${i.naturalHeight}`);
  const urls = [...document.querySelectorAll("*")].flatMap(e => [e.currentSrc || e.src, e.href,
    getComputedStyle(e).backgroundImage]).filter(u => u && u !== "none" && !u.startsWith("data:"));
  document.body.setAttribute("data-images", sizes.join(" "));
  document.body.setAttribute("data-resources", performance.getEntriesByType("resource").length);
  document.body.setAttribute("data-urls", urls.length);
});
</script>"""
"""Added to a copy of the page (the report itself has no script): what the browser decoded, how many resources
it fetched besides the page (Resource Timing: counted for http, not for file: URLs, hence the page is served
on localhost) and how many URLs that are not data: URLs its elements resolved."""


@contextmanager
def _served(folder):
    """``folder`` on http://127.0.0.1:<port>/ (a thread; stopped on exit)."""
    handler = functools.partial(SimpleHTTPRequestHandler, directory=str(folder))
    handler.log_message = lambda *args: None
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on this machine")
def test_chromium_decodes_every_view_of_report_html_and_fetches_nothing_else(tmp_path):
    t, _, measured, _ = plant_run(2.0, 1e-3, 1.0, drop_at_s=1.0)
    probes = ("x1", "y1", "x2", "y2")
    columns = {"time_s": t, **{f"{n}_um": measured[:, i] * 1e6 for i, n in enumerate(probes)}}
    record = write_record(tmp_path / "drop.csv", columns)
    assert main(["estimate", str(record), "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    page = (tmp_path / "out" / "report.html").read_text()
    (tmp_path / "out" / "probed.html").write_text(page.replace("</body>", PROBE + "</body>"))
    profile = f"--user-data-dir={tmp_path / 'profile'}"
    with _served(tmp_path / "out") as site:  # beside the PNG files: a page that linked them would load them
        dump = [CHROMIUM, *FLAGS, profile, "--virtual-time-budget=5000", "--dump-dom", f"{site}/probed.html"]
        process = subprocess.run(dump, capture_output=True, text=True, timeout=120)
    assert process.returncode == 0, process.stderr[-2000:]
    images = re.search(r'data-images="([^"]*)"', process.stdout)
    resources = re.search(r'data-resources="(\d+)"', process.stdout)
    urls = re.search(r'data-urls="(\d+)"', process.stdout)
    assert images and resources and urls, process.stdout[-2000:]
    sizes = images.group(1).split()
    assert len(sizes) == 4
    for size in sizes:  # decoded, at the size matplotlib drew (>= 600 px wide at 110 dpi)
        complete, dimensions = size.split(":")
        width, height = (int(v) for v in dimensions.split("x"))
        assert complete == "true" and width >= 600 and height >= 300, sizes
    assert int(resources.group(1)) == 0 and int(urls.group(1)) == 0  # data: URLs only, nothing fetched
    screenshot = tmp_path / "report.png"
    page_uri = (tmp_path / "out" / "report.html").as_uri()
    shot = [CHROMIUM, *FLAGS, profile, "--hide-scrollbars", "--window-size=1280,3600"]
    shot.append(f"--screenshot={screenshot}")
    subprocess.run([*shot, page_uri], capture_output=True, timeout=120, check=True)
    assert screenshot.stat().st_size > 50_000
    assert np.frombuffer(screenshot.read_bytes()[:8], np.uint8).tolist() == list(b"\x89PNG\r\n\x1a\n")
