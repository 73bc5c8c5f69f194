"""``report.html``: one self-contained page per output folder, for a reader with a web browser.

:func:`write_html` reads any output folder back through :func:`ecostudy.io.folder.load` (its
``summary.json``, its tables, its files) and writes ``report.html`` beside them: the folder's
status in the one vocabulary (``ok``, ``flagged: reason``, ``failed: reason``), the count of cases
by status and every case not ok with its reason, the inputs the command recorded, its results and
checks (verification, solver), every image it lists embedded as a data URI with its file name as
caption, and every table, sortable by a click on a column header. The page loads nothing: no
network, no fonts, no style sheet or script from elsewhere; it opens the same from a mail
attachment as from the folder. Column names are the CSV's, so units read as in the files.
"""
import base64
import html
import json
import math
from numbers import Number
from pathlib import Path
from typing import Any, Optional
from urllib.parse import quote

import pandas as pd

from ecostudy.core.status import status_word
from ecostudy.core.units import number
from ecostudy.report.cells import decimals, fmt_scalar, is_missing, numeric_cell
from ecostudy.io.folder import Counts, StudyResult, load
from ecostudy.io.writers import REPORT, SUMMARY, atomic_write

MAX_ROWS = 5000  # rows of a table shown on the page; the CSV beside it holds them all
IMAGES = {".png": "image/png", ".svg": "image/svg+xml"}
# summary fields that say what the command was asked (shown as inputs, in this order); the rest
# are results. A field a command records that is not named here is shown with the results.
INPUTS = ("study", "track", "train", "from", "to", "stops", "points", "count", "objective",
          "target_running_time_s", "steps", "dt_s", "workers", "warm_start")
# checks shown first among the nested fields
FIRST = ("verification", "solver")
MEANING = {"ok": "every case computed and every check passed",
           "flagged": "computed and written, but a check did not pass",
           "failed": "no usable result for at least one case"}
# the common fields of summary.json and a command's title, shown in the page's head
HEAD = ("kind", "ecostudy_version", "summary_layout", "status", "cases", "not_ok", "tables", "files", "title")

CSS = """
:root{--ok:#1b7f3b;--ok-bg:#e7f5ec;--flagged:#9a6100;--flagged-bg:#fff4db;--failed:#b3261e;--failed-bg:#fde8e7;
--line:#d9dde3;--muted:#5f6b7a;--head:#f4f6f8}
*{box-sizing:border-box}
body{margin:0;background:#fafbfc;color:#1f2933;font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,
"DejaVu Sans",sans-serif}
main{max-width:1140px;margin:0 auto;padding:28px 32px 48px}
h1{font-size:1.55rem;margin:0 0 4px;line-height:1.25}
h2{font-size:1.15rem;margin:34px 0 10px;padding-bottom:4px;border-bottom:1px solid var(--line)}
h3{font-size:.98rem;margin:18px 0 6px;color:#323f4b}
.sub{color:var(--muted);font-size:.88rem;margin:0 0 18px}
.status{border-radius:8px;padding:14px 18px;margin:10px 0 16px;border-left:6px solid;font-size:1.05rem}
.status b{font-size:1.3rem;margin-right:8px;text-transform:uppercase;letter-spacing:.04em}
.status small{display:block;color:#3e4c59;font-size:.85rem;margin-top:2px}
.st-ok{color:var(--ok);background:var(--ok-bg)}
.st-flagged{color:var(--flagged);background:var(--flagged-bg)}
.st-failed{color:var(--failed);background:var(--failed-bg)}
.counts{display:flex;gap:12px;flex-wrap:wrap;margin:0 0 8px}
.count{background:#fff;border:1px solid var(--line);border-radius:8px;padding:8px 16px;min-width:110px}
.count span{display:block;font-size:1.45rem;font-weight:600}
.count small{color:var(--muted);text-transform:uppercase;font-size:.72rem;letter-spacing:.05em}
.count.ok span{color:var(--ok)}.count.flagged span{color:var(--flagged)}.count.failed span{color:var(--failed)}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(330px,1fr));gap:8px 28px;align-items:start}
.scroll{max-height:520px;overflow:auto;border:1px solid var(--line);border-radius:6px;background:#fff}
table{border-collapse:collapse;font-size:.86rem;width:100%;background:#fff}
th,td{padding:4px 10px;border-bottom:1px solid #edf0f3;text-align:left;vertical-align:top}
td.n{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
table.data td{white-space:nowrap}table.data td.long{white-space:normal;min-width:15em}
table.data th{position:sticky;top:0;background:var(--head);cursor:pointer;user-select:none;
border-bottom:1px solid var(--line);font-weight:600;vertical-align:bottom}
table.data th:hover{background:#e8ecf0}
table.data th[aria-sort=ascending]::after{content:" \\25B2";font-size:.7em}
table.data th[aria-sort=descending]::after{content:" \\25BC";font-size:.7em}
table.data tbody tr:nth-child(even){background:#fafbfc}
table.kv{border:1px solid var(--line);table-layout:fixed}
table.kv th{width:46%;font-weight:500;color:#3e4c59;background:var(--head);overflow-wrap:anywhere}
table.kv td{overflow-wrap:anywhere}
td.s-ok{color:var(--ok)}td.s-flagged{color:var(--flagged);font-weight:600}
td.s-failed{color:var(--failed);font-weight:600}
.note{color:var(--muted);font-size:.85rem;margin:4px 0 0}
figure{margin:0 0 22px;background:#fff;border:1px solid var(--line);border-radius:6px;padding:10px}
figure img{display:block;max-width:100%;height:auto;margin:0 auto}
figcaption{text-align:center;color:var(--muted);font-size:.85rem;margin-top:6px;font-family:ui-monospace,monospace}
ul.files{columns:2;padding-left:18px}code{font-family:ui-monospace,"DejaVu Sans Mono",monospace;font-size:.9em}
footer{margin-top:40px;color:var(--muted);font-size:.8rem}
"""

# click a header: sort by that column (numbers by value, from data-v; text by locale), click again:
# the other way; empty cells last
JS = """
document.querySelectorAll("table.data").forEach(function (table) {
  var heads = table.tHead.rows[0].cells;
  Array.prototype.forEach.call(heads, function (th, col) {
    th.setAttribute("aria-sort", "none"); th.tabIndex = 0; th.title = "sort by " + th.textContent;
    function sort() {
      var down = th.getAttribute("aria-sort") === "ascending";
      Array.prototype.forEach.call(heads, function (h) { h.setAttribute("aria-sort", "none"); });
      th.setAttribute("aria-sort", down ? "descending" : "ascending");
      var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
      function key(row) {
        var c = row.cells[col];
        return c.hasAttribute("data-v") ? parseFloat(c.getAttribute("data-v")) : c.textContent;
      }
      rows.sort(function (a, b) {
        var x = key(a), y = key(b), ex = x === "" || x !== x, ey = y === "" || y !== y;
        if (ex || ey) { return ex - ey; }
        var r = (typeof x === "number" && typeof y === "number") ? x - y
          : String(x).localeCompare(String(y), undefined, {numeric: true});
        return down ? -r : r;
      });
      rows.forEach(function (r) { body.appendChild(r); });
    }
    th.addEventListener("click", sort);
    th.addEventListener("keydown", function (e) { if (e.key === "Enter") { sort(); } });
  });
});
"""


def write_html(folder: Path | str) -> Path:
    """Write ``report.html`` into an output folder of any command (atomically) and return its path.

    The folder is read back through :func:`ecostudy.io.folder.load`; a folder without a readable
    ``summary.json`` is refused as ``load`` refuses it (one line naming it, exit status 2).
    """
    result = load(folder)
    page = render(result)
    path = result.folder / REPORT
    atomic_write(path, lambda tmp: Path(tmp).write_text(page, encoding="utf-8"))
    return path


def render(result: StudyResult) -> str:
    """The whole page of an output folder as one HTML string."""
    s = result.summary
    own = {k: v for k, v in s.items() if k not in HEAD}
    inputs = {k: own.pop(k) for k in INPUTS if k in own}
    scalars = {k: v for k, v in own.items() if not isinstance(v, (dict, list))}
    nested = {k: v for k, v in own.items() if isinstance(v, (dict, list))}
    nested = {k: nested[k] for k in sorted(nested, key=lambda k: FIRST.index(k) if k in FIRST else len(FIRST))}
    title = page_title(result)
    parts = [f"<h1>{esc(title)}</h1>",
             f'<p class="sub">ecostudy {esc(s.get("ecostudy_version", "?"))} &middot; '
             f'<code>{esc(result.kind)}</code> output folder <code>{esc(result.folder.resolve())}</code></p>',
             status_box(str(result.status), result.status.kind), counts(result.cases)]
    if result.not_ok:
        parts.append(f"<h2>Cases not ok ({len(result.not_ok)})</h2>")
        parts.append(data_table(pd.DataFrame([{"case": r.case, "status": str(r.status)} for r in result.not_ok])))
    inputs_json = read_inputs(result)
    parts.append("<h2>Inputs</h2>")
    if inputs or inputs_json:
        parts.append('<div class="grid">' + (kv_table(inputs) if inputs else "")
                     + (f"<div><h3>inputs.json</h3>{kv_table(inputs_json)}</div>" if inputs_json else "") + "</div>")
    else:
        parts.append(f'<p class="note">The {esc(result.kind)} command records no inputs in {SUMMARY}.</p>')
    if scalars:
        parts += ["<h2>Results</h2>", '<div class="grid">' + "".join(map(kv_table, chunks(scalars))) + "</div>"]
    if nested:
        parts.append("<h2>Checks and details</h2>")
        parts.append('<div class="grid">' + "".join(block(k, v) for k, v in nested.items()) + "</div>")
    images = [f for f in result.files if Path(f).suffix.lower() in IMAGES]
    if images:
        parts.append("<h2>Figures</h2>")
        parts += [figure(result.folder, f) for f in images]
    for name, frame in result.tables.items():
        file = (s.get("tables") or {}).get(name, "")
        parts.append(f"<h2>Table {esc(name)} <small class=\"note\">{esc(file)}, {len(frame)} rows</small></h2>")
        parts.append(data_table(frame, scroll=True))
    parts.append(files_list(result))
    parts.append(f'<footer>Written by ecostudy {esc(s.get("ecostudy_version", "?"))} from '
                 f"<code>{SUMMARY}</code>; click a column header to sort a table.</footer>")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{esc(title)} - {esc(result.status.kind)}</title><style>{CSS}</style></head>\n"
            "<body><main>\n" + "\n".join(parts) + f"\n</main><script>{JS}</script></body></html>\n")


def fragment(title: str, status: str, values: dict | None = None, frame: pd.DataFrame | None = None,
             rows: int = 20) -> str:
    """A result in a notebook cell (its ``_repr_html_``): its ``title``, its status (``ok``,
    ``flagged: reason``) and its ``values`` as a key-value table or the first ``rows`` rows of
    ``frame``, in this page's cells (no style sheet: the notebook's own)."""
    word, _, reason = status.partition(":")
    parts = [f"<p><code>{esc(title)}</code>: <b>{esc(word)}</b>" + (f": {esc(reason.strip())}" if reason else "")
             + "</p>"]
    if values:
        parts.append(kv_table(values))
    if frame is not None:
        parts.append(data_table(frame.head(rows)))
        if len(frame) > rows:
            parts.append(f'<p class="note">The first {rows} of {len(frame)} rows.</p>')
    return "<div>" + "".join(parts) + "</div>"


def page_title(result: StudyResult) -> str:
    """The command, then the study, track and train names and the stops where the summary has them."""
    s = result.summary
    names = [str(s[k]) for k in ("title", "study", "track", "train") if s.get(k) not in (None, "")]
    if s.get("from") is not None and s.get("to") is not None:
        names.append(f"{s['from']} \u2192 {s['to']}")
    return " \u00b7 ".join([f"ecostudy {result.kind}"] + list(dict.fromkeys(names)))


def status_box(text: str, kind: str) -> str:
    word, _, reason = text.partition(":")
    return (f'<div class="status st-{esc(kind)}" id="status"><b>{esc(word)}</b>'
            f"{esc(reason.strip())}<small>{esc(MEANING.get(kind, ''))}</small></div>")


def chunks(values: dict, rows: int = 8) -> list[dict]:
    """A long key-value list cut into up to three balanced columns."""
    items = list(values.items())
    size = math.ceil(len(items) / min(3, math.ceil(len(items) / rows)))
    return [dict(items[i:i + size]) for i in range(0, len(items), size)]


def counts(cases: Counts) -> str:
    tiles = [f'<div class="count {k}"><span>{getattr(cases, k)}</span><small>{label}</small></div>'
             for k, label in (("total", "cases"), ("ok", "ok"), ("flagged", "flagged"), ("failed", "failed"))]
    return '<div class="counts" id="cases">' + "".join(tiles) + "</div>"


def read_inputs(result: StudyResult) -> dict:
    """The ``inputs.json`` a solve folder keeps beside its summary (input files, their hashes), when
    the summary lists it: a file the summary does not list may be left from another run."""
    path = result.folder / "inputs.json"
    if path.name not in result.files:
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def block(name: str, value: Any) -> str:
    """A nested summary field: its scalars as a key-value table, its lists of records as tables."""
    if isinstance(value, list):
        value = {"": value}
    flat: dict = {}
    lists: dict = {}
    flatten(value, "", flat, lists)
    out = [f"<div><h3>{esc(name)}</h3>"]
    if flat:
        out.append(kv_table(flat))
    for key, rows in lists.items():
        if key:
            out.append(f'<p class="note">{esc(key)}</p>')
        out.append(data_table(pd.DataFrame(rows)))
    return "".join(out) + "</div>"


def flatten(value: dict, prefix: str, flat: dict, lists: dict) -> None:
    for k, v in value.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            flatten(v, key + ".", flat, lists)
        elif isinstance(v, list) and v and all(isinstance(r, dict) for r in v):
            lists[key] = v
        elif isinstance(v, list):
            flat[key] = ", ".join(fmt_scalar(x) for x in v) if v else "none"
        else:
            flat[key] = v


def kv_table(values: dict) -> str:
    rows = []
    for k, v in values.items():
        cls = "n" if is_number(v) else status_class(k, v)
        num = f' class="{cls}"' if cls else ""
        rows.append(f"<tr><th>{wrap(k)}</th><td{num}>{esc(fmt_scalar(v))}</td></tr>")
    return '<table class="kv"><tbody>' + "".join(rows) + "</tbody></table>"


def data_table(frame: pd.DataFrame, scroll: bool = False) -> str:
    """A sortable table: every column formatted once (numbers to a precision its magnitude asks)."""
    shown = frame.head(MAX_ROWS)
    cols = []
    for name in shown.columns:
        col = shown[name]
        if pd.api.types.is_bool_dtype(col) or not pd.api.types.is_numeric_dtype(col):
            cols.append([cell(name, v) for v in col])
        else:
            places, values = decimals(col), col.dropna().astype(float).abs()
            largest = float(values[values.map(math.isfinite)].max()) if len(values) else 0.0
            cols.append([numeric_cell(v, places, largest) for v in col])
    head = "".join(f"<th>{wrap(c)}</th>" for c in shown.columns)
    body = "".join("<tr>" + "".join(row) + "</tr>" for row in zip(*cols)) if cols else ""
    table = f'<table class="data"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'
    if scroll:
        table = f'<div class="scroll">{table}</div>'
    if len(frame) > MAX_ROWS:
        table += f'<p class="note">The first {MAX_ROWS} of {len(frame)} rows; the CSV file holds them all.</p>'
    return table


def cell(column: str, value: Any) -> str:
    """A text cell: on one line unless long, coloured where it is a status."""
    if is_missing(value):
        return "<td></td>"
    text = fmt_scalar(value)
    classes = " ".join(c for c in (status_class(column, value), "long" if len(text) > 24 else "") if c)
    return f'<td class="{classes}">{esc(text)}</td>' if classes else f"<td>{esc(text)}</td>"


def is_number(v: Any) -> bool:
    return isinstance(v, Number) and not isinstance(v, bool) and not is_missing(v)


def status_class(column: str, value: Any) -> str:
    """Colour a status cell by its word (ok, flagged, failed) where the column is a status."""
    if "status" not in str(column) or not isinstance(value, str):
        return ""
    word = status_word(value)
    kind = {"infeasible": "failed", "missing": "failed"}.get(word, word)
    return f"s-{kind}" if kind in ("ok", "flagged", "failed") else ""


def figure(folder: Path, name: str) -> str:
    """An image of the folder embedded as a data URI, its file name as caption."""
    try:
        data = base64.b64encode((folder / name).read_bytes()).decode("ascii")
    except OSError as exc:
        return (f'<figure><p class="note">{esc(name)} is listed but cannot be read '
                f"({esc(exc.strerror or exc)}).</p><figcaption>{esc(name)}</figcaption></figure>")
    mime = IMAGES[Path(name).suffix.lower()]
    return (f'<figure><img src="data:{mime};base64,{data}" alt="{esc(name)}">'
            f"<figcaption>{esc(name)}</figcaption></figure>")


def files_list(result: StudyResult) -> str:
    """The files of the folder, each a link relative to the page (they open where it was written)."""
    items = "".join(f'<li><a href="./{esc(quote(f))}"><code>{esc(f)}</code></a></li>'
                    for f in result.files if f != REPORT)
    return f'<h2>Files in this folder</h2><ul class="files">{items}</ul>' if items else ""


def wrap(name: Any) -> str:
    """A column or field name, escaped, that may break after its underscores."""
    return esc(name).replace("_", "_<wbr>").replace(".", ".<wbr>")


def esc(value: Any) -> str:
    return html.escape(str(value), quote=True)
