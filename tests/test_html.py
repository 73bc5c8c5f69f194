"""report.html of an output folder: built from real runs (tiny grids), read back as HTML, and
rendered in headless Chromium (Debian's ``chromium``), where its tables, images and sorting are
checked in the page the browser built."""
import base64
import re
import shutil
import struct
import subprocess
from html.parser import HTMLParser

from matplotlib.figure import Figure

import pandas as pd
import pytest
from typer.testing import CliRunner

from ecostudy import __version__
from ecostudy.cli import app
from ecostudy.core.status import OK, failed, flagged
from ecostudy.io.folder import load, write_summary
from ecostudy.io.writers import write_csv, write_json
from ecostudy.report.html import MAX_ROWS, write_html

from .conftest import ROOT, TRACKS, TRAINS

CHROMIUM = shutil.which("chromium")
needs_chromium = pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium is not installed (Debian package "
                                    "`chromium`; scripts/install.sh installs it, CI runs this test)")


class Page(HTMLParser):
    """What a reader's browser gets from a page: its tables (head and body rows, cell texts and
    attributes), images, captions, scripts, links and the status box."""

    def __init__(self, text):
        super().__init__()
        self.tables, self.images, self.captions, self.scripts, self.links = [], [], [], [], []
        self.heads, self.status, self.title = [], "", ""
        self._cell = self._in = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self.tables.append({"class": a.get("class", ""), "head": [], "rows": []})
        elif tag == "tr" and self.tables:
            self.tables[-1]["rows"].append([])
        elif tag in ("td", "th") and self.tables:
            self._cell = {"tag": tag, "text": "", **a}
        elif tag == "img":
            self.images.append(a)
        elif tag == "script":
            self.scripts.append(a)
        elif tag in ("a", "link"):
            self.links.append(a.get("href", ""))
        if tag in ("figcaption", "title", "script") or a.get("id") == "status":
            self._in = "status" if a.get("id") == "status" else tag
            if tag == "figcaption":
                self.captions.append("")

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1]["rows"][-1].append(self._cell)
            self._cell = None
        elif tag in ("figcaption", "title", "script", "div") and self._in:
            self._in = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell["text"] += data
        if self._in == "figcaption":
            self.captions[-1] += data
        elif self._in == "status":
            self.status += data
        elif self._in == "title":
            self.title += data

    def table(self, columns):
        """The data table whose header row is ``columns``: its body rows as lists of cells."""
        for t in self.tables:
            if "data" in t["class"] and t["rows"] and [c["text"] for c in t["rows"][0]] == list(columns):
                return t["rows"][1:]
        raise AssertionError(f"no table with columns {list(columns)}")


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    """The folders of a real solve and a real front (K = 200), each with its report.html."""
    base = tmp_path_factory.mktemp("reports")
    runner = CliRunner()
    commands = {"solve": ["solve", str(ROOT / "studies" / "default.yaml"), "--points", "200"],
                "pareto": ["pareto", "--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"), "--train",
                           str(TRAINS / "amsterdam_metro.yaml"), "--count", "3", "--points", "200"]}
    for name, args in commands.items():
        out = runner.invoke(app, [*args, "--out", str(base / name)])
        assert out.exit_code == 0, out.output
    return {name: write_html(base / name) for name in commands}


def counts(path):
    """The case counts the page's tiles show."""
    return {k: int(n) for k, n in re.findall(r'<div class="count (\w+)"><span>(\d+)</span>', path.read_text())}


def png_size(data):
    return struct.unpack(">II", data[16:24])  # width, height from the PNG's IHDR chunk


def check_page(path):
    """What every report must hold: every table with all its rows, every image embedded whole with
    its name as caption, nothing loaded from elsewhere. Returns the parsed page."""
    result = load(path.parent)
    page = Page(path.read_text(encoding="utf-8"))
    assert page.title.startswith(f"ecostudy {result.kind}")
    assert page.status.strip().startswith(result.status.kind)
    assert counts(path) == {"total": result.cases.ok + result.cases.flagged + result.cases.failed,
                            **{k: getattr(result.cases, k) for k in ("ok", "flagged", "failed")}}
    assert __version__ in path.read_text()
    for name, frame in result.tables.items():
        rows = page.table(frame.columns)
        assert len(rows) == min(len(frame), MAX_ROWS), name  # a longer table: its first rows, and a note
        assert (len(frame) > MAX_ROWS) == (f"The first {MAX_ROWS} of {len(frame)} rows" in path.read_text())
    pictures = [f for f in result.files if f.endswith((".png", ".svg"))]
    assert pictures and page.captions == pictures
    for img, name in zip(page.images, pictures):
        head, _, data = img["src"].partition(",")
        assert head == "data:image/png;base64" and base64.b64decode(data) == (path.parent / name).read_bytes()
    assert all(not s.get("src") for s in page.scripts)  # the one script is inline
    assert all(link.startswith("./") for link in page.links)  # no link out of the folder
    assert "http://" not in path.read_text() and "https://" not in path.read_text()
    return page


def test_report_of_a_solve(reports):
    page = check_page(reports["solve"])
    assert "Amsterdam metro (Alstom, Rokin-Centraal case)" in page.title and "Rokin \u2192 Centraal" in page.title
    assert page.status.strip().startswith("ok")
    fields = {r[0]["text"]: r[1]["text"] for t in page.tables if t["class"] == "kv" for r in t["rows"]}
    summary = load(reports["solve"].parent).summary
    assert fields["objective"] == "energy" and fields["points"] == "200"  # inputs
    assert float(fields["traction_energy_kWh"]) == pytest.approx(summary["traction_energy_kWh"], rel=1e-3)
    assert fields["passed"] == "yes" and "arrival_time_error_s" in fields  # the verification block
    profile = load(reports["solve"].parent).tables["profile"]
    rows = page.table(profile.columns)
    speed = list(profile.columns).index("speed_kmh")
    assert [float(r[speed]["data-v"]) for r in rows] == pytest.approx(profile["speed_kmh"].tolist())
    assert all(r[speed]["text"].count(".") == 1 and len(r[speed]["text"].split(".")[1]) == 2 for r in rows)


def test_report_of_a_front(reports):
    page = check_page(reports["pareto"])
    front = load(reports["pareto"].parent).tables["pareto"]
    rows = page.table(front.columns)
    status = list(front.columns).index("status")
    assert [r[status]["text"] for r in rows] == front["status"].tolist()
    assert all(r[status]["class"] == "s-ok" for r in rows)
    assert page.captions == ["pareto.png", "pareto_profiles.png"]


def test_report_lists_cases_not_ok_and_escapes_text(tmp_path):
    """Names and reasons with markup in them are shown as text, never run; the cases not ok are
    listed with their reasons; numbers get the precision of their column."""
    write_csv(tmp_path / "cases.csv", pd.DataFrame({"case": ["<b>a</b>", "b", "c"],
                                                    "energy_kWh": [1234.56, 0.5, None],
                                                    "status": ["flagged: <script>alert(1)</script>", "failed: x & y",
                                                               "ok"]}))
    fig = Figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    for form in ("svg", "pdf"):
        fig.savefig(tmp_path / f"line.{form}")
    write_json(tmp_path / "inputs.json", {"track": "/tracks/<i>line</i>.yaml", "points": 200})
    write_summary(tmp_path, "run", {"<b>a</b>": flagged("<script>alert(1)</script>"), "b": failed("x & y"), "c": OK},
                  {"cases": "cases.csv"}, ["line.svg", "line.pdf", "inputs.json"],
                  study="<img src=x onerror=alert(2)>.yaml")
    path = write_html(tmp_path)
    page = Page(path.read_text())
    assert len(page.scripts) == 1  # the markup in names and reasons stayed text
    assert [i["alt"] for i in page.images] == ["line.svg"] and page.captions == ["line.svg"]  # a PDF is only listed
    head, _, data = page.images[0]["src"].partition(",")
    assert head == "data:image/svg+xml;base64" and base64.b64decode(data) == (tmp_path / "line.svg").read_bytes()
    assert "./line.pdf" in page.links
    fields = {r[0]["text"]: r[1]["text"] for t in page.tables if t["class"] == "kv" for r in t["rows"]}
    assert fields == {"study": "<img src=x onerror=alert(2)>.yaml", "track": "/tracks/<i>line</i>.yaml",
                      "points": "200"}  # the inputs, from the summary and the inputs.json it lists
    assert page.status.strip().startswith("failed") and "x & y" in page.status
    assert "<img src=x onerror=alert(2)>.yaml" in page.title
    not_ok = page.table(["case", "status"])
    assert [[c["text"] for c in r] for r in not_ok] == [["<b>a</b>", "flagged: <script>alert(1)</script>"],
                                                        ["b", "failed: x & y"]]
    assert [r[1]["class"].split()[0] for r in not_ok] == ["s-flagged", "s-failed"]
    cases = page.table(["case", "energy_kWh", "status"])
    assert [r[1]["text"] for r in cases] == ["1\u2009234.6", "0.5", ""]
    assert float(cases[0][1]["data-v"]) == 1234.56
    assert counts(path) == {"total": 3, "ok": 1, "flagged": 1, "failed": 1}


def test_a_folder_without_summary_is_refused(tmp_path):
    from ecostudy.core.errors import InputError
    with pytest.raises(InputError, match="summary.json"):
        write_html(tmp_path)
    assert not (tmp_path / "report.html").exists()


def chromium(url, tmp_path, *flags):
    """The DOM headless Chromium built from a page (its scripts run), as text."""
    out = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                          f"--user-data-dir={tmp_path / 'profile'}", *flags, "--dump-dom", url],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and "</html>" in out.stdout, out.stderr[-2000:]
    return out.stdout


@needs_chromium
@pytest.mark.parametrize("kind", ["solve", "pareto"])
def test_chromium_renders_tables_images_and_sorts(reports, kind, tmp_path):
    path = reports[kind]
    result = load(path.parent)
    dom = Page(chromium(path.as_uri(), tmp_path))
    for name, frame in result.tables.items():  # every table, every row, each header made sortable by the script
        rows = dom.table(frame.columns)
        assert len(rows) == len(frame), name
    data_tables = [t for t in dom.tables if "data" in t["class"]]
    assert all(c.get("aria-sort") == "none" for t in data_tables for c in t["rows"][0])
    pictures = [f for f in result.files if f.endswith(".png")]
    assert [i["alt"] for i in dom.images] == pictures
    assert all(i["src"].startswith("data:image/png;base64,") for i in dom.images)

    # the same page, clicked: the browser decodes each image to its file's size, and two clicks on a
    # numeric column's header sort the table by it, largest first
    frame = next(iter(result.tables.values()))
    column = next(c for c in frame.columns if pd.api.types.is_float_dtype(frame[c]))
    col = list(frame.columns).index(column)
    probe = tmp_path / "probe.html"  # the page is self-contained: it renders the same from anywhere
    probe.write_text(path.read_text().replace("</body>", f"""<script>window.addEventListener("load", function () {{
      document.querySelectorAll("img").forEach(function (i) {{
        i.setAttribute("data-size", i.naturalWidth + "x" + i.naturalHeight); }});
      var th = document.querySelector("div.scroll table.data").tHead.rows[0].cells[{col}];
      th.click(); th.click(); }});</script></body>"""))
    dom = Page(chromium(probe.as_uri(), tmp_path))
    for img, name in zip(dom.images, pictures):
        assert img["data-size"] == "{}x{}".format(*png_size((path.parent / name).read_bytes()))
    rows = dom.table(frame.columns)
    shown = [float(r[col]["data-v"]) for r in rows if r[col].get("data-v")]
    assert shown == sorted(frame[column].dropna(), reverse=True)
    head = next(t["rows"][0] for t in dom.tables if [c["text"] for c in t["rows"][0]] == list(frame.columns))
    assert head[col]["aria-sort"] == "descending"


def test_a_runs_inputs_read_as_their_fields_not_as_python_writes_them(tmp_path):
    """report.html's Inputs showed `timing {'running_time_s': 78.0, 'supplement_percent': None,
    'window_s': None}` and `windows []`; the pareto --das table printed `None` where the other
    columns print NaN."""
    from ecostudy.api.outcome import shown
    r = CliRunner().invoke(app, ["solve", "--track", str(TRACKS / "amsterdam_rokin_centraal.yaml"), "--train",
                                 str(TRAINS / "amsterdam_metro.yaml"), "--time", "78", "--points", "60", "--no-plot",
                                 "--out", str(tmp_path / "s")])
    assert r.exit_code in (0, 1), r.output
    page = (tmp_path / "s" / "report.html").read_text()
    assert "{&#x27;" not in page and "{'" not in page and "[]" not in page, re.findall(r"<td>[^<]*[\[{][^<]*</td>", page)
    assert "running_time_s 78" in page
    table = shown(pd.DataFrame({"gap": [None, None], "energy": [1.0, None]}))
    assert "None" not in table and table.split("\n")[1].split() == ["NaN", "1.000"], table
