"""The report laid out by a real browser (Debian's chromium, headless; skipped where none is installed): at a
1280 px window the page does not overflow horizontally, every table of ``REPORT_PARTS`` is on the page and
inside the window, every image is loaded; printed (A4), every section starts its own page. The drive with
the most pulleys of the examples, six duty points with status texts: the widest page the report makes."""

import json
import re
import shutil
import subprocess
import tempfile

import pytest
from helpers import CASES, EXAMPLES, accessory_drive, synthetic_duty

from jaxbelt.analysis.report import REPORT_PARTS, ReportSource, drive_report

CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser") if shutil.which(n)), None)
pytestmark = [
    pytest.mark.skipif(CHROMIUM is None, reason="no chromium installed (.ci/run installs Debian's)"),
    pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements"),
]
WIDTH = 1280
# run by the browser once the page (and its images) loaded: the measurements written into the DOM, read back
# from --dump-dom
MEASURE = """<script>window.addEventListener("load", () => {
  const right = (e) => Math.ceil(e.getBoundingClientRect().right);
  const m = {
    scrollWidth: document.documentElement.scrollWidth,
    clientWidth: document.documentElement.clientWidth,
    innerWidth: window.innerWidth,
    tables: Object.fromEntries([...document.querySelectorAll("table")].map((t) => [t.id, right(t)])),
    images: Object.fromEntries([...document.images].map((i) => [i.alt, [i.complete, i.naturalWidth, right(i)]])),
    sections: document.querySelectorAll("section.page").length,
  };
  const out = document.createElement("pre");
  out.id = "layout-measure";
  out.textContent = JSON.stringify(m);
  document.body.appendChild(out);
});</script>"""


def _chromium(*args, timeout=120) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory(prefix="jaxbelt-chromium-") as profile:  # its own profile: runs side by side
        cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run"]
        cmd.append(f"--user-data-dir={profile}")
        return subprocess.run([*cmd, *args], capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def page_file(tmp_path_factory):
    drive = accessory_drive()
    duty = synthetic_duty(drive, rpm=(800.0, 1500.0, 2000.0, 3000.0, 4500.0, 6000.0))
    text = (EXAMPLES / "accessory_drive.toml").read_text()
    source = ReportSource(path=str(EXAMPLES / "accessory_drive.toml"), text=text, command="jaxbelt report ...")
    html = drive_report(drive, length_cases=CASES, duty=duty, source=source)
    path = tmp_path_factory.mktemp("report") / "report.html"
    path.write_text(html)
    return path


def test_no_horizontal_overflow_and_every_part_laid_out(page_file):
    measured = page_file.with_name("measured.html")
    measured.write_text(page_file.read_text().replace("</body>", MEASURE + "</body>"))
    out = _chromium(f"--window-size={WIDTH},900", "--virtual-time-budget=10000", "--dump-dom", measured.as_uri())
    found = re.search(r'<pre id="layout-measure">(.*?)</pre>', out.stdout)
    assert found, out.stderr[-2000:]
    m = json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&"))
    assert m["innerWidth"] == WIDTH
    assert m["scrollWidth"] <= m["clientWidth"] <= WIDTH, m  # nothing wider than the window: no sideways scroll
    for table in REPORT_PARTS["tables"] + REPORT_PARTS["duty_tables"]:
        assert table in m["tables"] and m["tables"][table] <= m["clientWidth"], (table, m["tables"].get(table))
    for alt in REPORT_PARTS["images"] + REPORT_PARTS["duty_images"]:
        complete, natural, right = m["images"][alt]
        assert complete and natural > 300 and right <= m["clientWidth"], (alt, m["images"][alt])
    assert m["sections"] == 7  # document, geometry, statics, tensioners, modes, duty points, input


def _pdf_pages(html_file) -> int:
    pdf = html_file.with_suffix(".pdf")
    out = _chromium("--no-pdf-header-footer", f"--print-to-pdf={pdf}", html_file.as_uri())
    assert pdf.exists(), out.stderr[-2000:]
    return len(re.findall(rb"/Type\s*/Page(?!s)", pdf.read_bytes()))


def test_printed_every_section_starts_a_page(page_file):
    # the page breaks add pages: the same page printed without them has fewer; every section at least one
    text = page_file.read_text()
    sections = text.count('<section class="page"')
    flowing = page_file.with_name("flowing.html")
    flowing.write_text(text.replace("section.page{break-before:page;", "section.page{"))
    assert flowing.read_text() != text
    pages, pages_flowing = _pdf_pages(page_file), _pdf_pages(flowing)
    assert pages >= sections == 7 and pages > pages_flowing
