"""`jaxbelt report`: the HTML page holds every table and image it names, with the statics' and modes' numbers."""

import html.parser
import subprocess
import sys
from pathlib import Path

from jaxbelt.analysis.report import REPORT_PARTS


class _Parts(html.parser.HTMLParser):
    def __init__(self):
        super().__init__()
        self.tables, self.images, self.rows, self._table = {}, [], {}, None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self._table = a.get("id")
            self.tables[self._table] = 0
        elif tag == "tr" and self._table is not None:
            self.tables[self._table] += 1
        elif tag == "img":
            self.images.append((a.get("alt"), a.get("src", "")))

    def handle_endtag(self, tag):
        if tag == "table":
            self._table = None


def test_report_page_has_every_table_and_image(tmp_path):
    cfg = Path(__file__).parent.parent / "examples" / "serpentine_tensioner.toml"
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "jaxbelt",
            "report",
            str(cfg),
            "--out",
            str(tmp_path),
            "--length-tolerance",
            "4",
            "--wear",
            "8",
            "--torque",
            "alternator=4",
        ],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    page = (tmp_path / "report.html").read_text()
    parts = _Parts()
    parts.feed(page)
    for table in REPORT_PARTS["tables"]:
        assert parts.tables.get(table, 0) >= 2, (table, parts.tables)  # header row + data
    assert parts.tables["tensioners"] == 1 + 4  # nominal, shortest, longest, worn
    alts = {alt: src for alt, src in parts.images}
    for image in REPORT_PARTS["images"]:
        assert alts.get(image, "").startswith("data:image/png;base64,") and len(alts[image]) > 2000, image
    assert "duty" not in parts.tables  # no --rpm: no duty section
    # the installation table carries the statics' figures: the alternator's 4 N m as its tension step
    from jaxbelt.analysis.statics import statics
    import jaxbelt as jb

    st = statics(jb.build_drive(jb.load_config(cfg)), {"alternator": 4.0})
    assert f"{st.pulleys['alternator']['hub_load']:.4g}" in page
