"""The report's document model and its Jinja2 rendering: one source, Markdown and HTML.

A report is a list of :class:`Section` objects. Each is a small template in
``impactbench/templates/sections/`` and a data function ``data(ctx) -> dict | None`` (``None``
leaves the section out). A section template is written once and rendered twice, with ``m``
bound to the Markdown macros (``templates/md.j2``) and then to the HTML macros
(``templates/html.j2``), which share their names and arguments: ``m.h(level, text)``,
``{% call m.para() %}…{% endcall %}``, ``m.note``, ``m.ul(items)``, ``m.table(Table)``,
``m.figure(FigureRef)``, ``m.figures(list)``, ``m.link(text, url)``. Prose uses inline Markdown
(``**bold**``, ```code```, ``[text](url)``), which the HTML side converts. The page templates
(``page.md.j2``, ``page.html.j2``) add the title, the table of contents and the style.

To add a section: write ``templates/sections/NAME.j2``, a data function, and put
``Section("NAME", "Title", data)`` in :func:`impactbench.report_sections.sections`.
"""

from __future__ import annotations

import html
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jinja2
import numpy as np
import pandas as pd

BANDS: tuple[tuple[str, float, str], ...] = (
    ("good", 0.01, "within 1 %"),
    ("fair", 0.05, "within 5 %"),
    ("poor", float("inf"), "more than 5 % off"),
)
"""Error bands of the scoreboard and the tables: name, upper bound of |relative error|, words."""
MARKS = {"good": "🟢", "fair": "🟡", "poor": "🔴", "na": "⚪", "fail": "⛔"}
"""How a band shows in Markdown (HTML colours the cell)."""


def band(err: float | None) -> str:
    """The band of a relative error: good, fair, poor, or na when it is not a number."""
    if err is None or not isinstance(err, int | float) or err != err:
        return "na"
    return next(name for name, bound, _ in BANDS if abs(err) <= bound)


@dataclass(frozen=True)
class Cell:
    """A table cell: its text (inline Markdown), an optional band (colour) and tooltip."""

    text: str
    band: str = ""
    title: str = ""
    wrap: bool = False


@dataclass(frozen=True)
class Table:
    """Columns and rows of cells; the first ``text_columns`` are left-aligned labels.

    ``marks``: show the bands as coloured marks in Markdown too (HTML always colours);
    ``prose_columns``: the last columns hold sentences (left-aligned, wrapping)."""

    columns: Sequence[str]
    rows: Sequence[Sequence[Cell | str]]
    text_columns: int = 1
    marks: bool = False
    prose_columns: int = 0

    @property
    def alignments(self) -> list[str]:
        """``left`` for the label and the trailing prose columns, ``right`` for numbers."""
        n = len(self.columns)
        return ["left" if i < self.text_columns or i >= n - self.prose_columns else "right"
                for i in range(n)]


@dataclass(frozen=True)
class FigureRef:
    """A figure of the report: its path relative to the report folder, caption and group."""

    path: str
    caption: str
    group: str = ""


@dataclass
class ReportContext:
    """Everything a section's data function may use.

    ``df``: the tidy results (one row per run and metric, :func:`impactbench.matrix.tidy`);
    ``results``: the runs with their thinned histories; ``meta``: what ``metadata.json`` holds;
    ``figures``: the report's plots (sections may add their own with :meth:`add_figure`)."""

    cfg: Any
    df: pd.DataFrame
    meta: dict[str, Any]
    out_dir: Path
    results: Sequence[Any] = ()
    figures: list[FigureRef] = field(default_factory=list)
    show_progress: bool = False
    """Whether a section that runs work of its own reports its progress on stderr."""
    store: Any = None
    """The report's results store (:class:`impactbench.report_store.KeepWhatFits`), which a
    section that runs work of its own uses when its store is the same file."""
    pool: Any = None
    """Where :meth:`draw` draws (a :class:`FigurePool`); None: here, at once."""
    background: dict[str, Any] = field(default_factory=dict)
    """Work the report started while the engines ran, by name (each ``result()`` its value:
    :meth:`~impactbench.scenarios.spec.ScenarioSpec.report_background`)."""

    @property
    def fig_dir(self) -> Path:
        return self.out_dir / "figures"

    @property
    def matrix(self) -> pd.DataFrame:
        """The rows of the comparison matrix (not the work-precision or other studies)."""
        if self.df.empty:
            return self.df
        return self.df[self.df.study == "matrix"]

    @property
    def engines(self) -> list[str]:
        """The engines of the results, in the config's order."""
        present = set(self.df.engine) if not self.df.empty else set()
        return [e for e in self.cfg.engines if e in present] + sorted(
            present - set(self.cfg.engines))

    def add_figure(self, path: Path, caption: str, group: str = "") -> FigureRef:
        ref = FigureRef(path.relative_to(self.out_dir).as_posix(), caption, group)
        self.figures.append(ref)
        return ref

    def figures_in(self, group: str) -> list[FigureRef]:
        return [f for f in self.figures if f.group == group]

    def draw(self, fn: Callable[..., Path], *args: Any, **kwargs: Any) -> Path:
        """``fn(*args, **kwargs)``, a plot function that writes one PNG to its ``path``
        argument and returns it: on the context's :class:`FigurePool` when it has one (the
        path is returned at once, the file is there when the pool closes), else here."""
        if self.pool is None:
            return fn(*args, **kwargs)
        return self.pool.submit(fn, *args, **kwargs)


class FigurePool:
    """A report's figures drawn in worker processes while the report goes on (matplotlib's
    Agg draws a figure in ~0.3–3 s of pure CPU; a default report has ~50): one process per
    core available (:func:`impactbench.figures.pool.process_pool`: forked from a fork server,
    SIGINT left to this process) (at most ``workers``; 0: none, every figure drawn here), each
    figure a task, its arguments pickled (the plot functions are module-level and take plain
    data). The processes start only once :data:`MIN_PARALLEL` figures are queued (a worker's
    imports cost about what two figures do): a small report draws here.
    :meth:`close` draws or waits for every figure and raises the first error a figure raised.
    The same bytes as drawn here: each figure is the same function of the same arguments."""

    MIN_PARALLEL = 8

    def __init__(self, workers: int | None = None) -> None:
        from impactbench.cluster import available_cores

        self.workers = 0 if workers == 0 else max(1, min(workers or available_cores(),
                                                         available_cores()))
        self._queued: list[tuple[Callable[..., Path], tuple, dict]] = []
        self._futures: list[Any] = []
        self._executor: Any = None

    def submit(self, fn: Callable[..., Path], *args: Any, **kwargs: Any) -> Path:
        """Queue ``fn(*args, **kwargs)``; its ``path`` argument (where it writes)."""
        import inspect

        path = Path(inspect.signature(fn).bind(*args, **kwargs).arguments["path"])
        if self._executor is not None:
            self._futures.append(self._executor.submit(fn, *args, **kwargs))
            return path
        self._queued.append((fn, args, kwargs))
        if len(self._queued) >= self.MIN_PARALLEL:
            self.start()
        return path

    def start(self) -> bool:
        """Start the worker processes now (when there are to be any): True if they run."""
        if self._executor is None and self.workers > 1:
            from impactbench.figures.pool import process_pool

            self._executor = process_pool(self.workers)
            self._futures += [self._executor.submit(f, *a, **k) for f, a, k in self._queued]
            self._queued = []
        return self._executor is not None

    def call(self, fn: Callable[[], Any]) -> Any:
        """``fn()`` (picklable) in a worker process when the workers run (:meth:`start`),
        else here when its value is first asked for: an object whose ``result()`` is it."""
        if self._executor is not None:
            return self._executor.submit(fn)
        return _Later(fn)

    def close(self) -> None:
        """Draw what is queued here, wait for the rest (the first error a figure raised is
        raised here)."""
        try:
            for fn, args, kwargs in self._queued:
                fn(*args, **kwargs)
            for fut in self._futures:
                fut.result()
        finally:
            self._queued, self._futures = [], []
            if self._executor is not None:
                self._executor.shutdown(wait=True, cancel_futures=True)
                self._executor = None

    def end(self) -> None:
        """End the workers at once, whatever they still do (a report that keeps its previous
        files needs none of it); nothing after :meth:`close`."""
        if self._executor is not None:
            from impactbench.figures.pool import end_now

            end_now(self._executor)
            self._executor = None

    def __enter__(self) -> FigurePool:
        return self

    def __exit__(self, *exc: object) -> None:
        if exc[0] is None:
            self.close()
        else:  # the report's own error: its figures do not matter
            self.end()


class _Later:
    """A value computed here when first asked for (:meth:`FigurePool.call` without workers)."""

    def __init__(self, fn: Callable[[], Any]) -> None:
        self._fn: Callable[[], Any] | None = fn
        self._value: Any = None

    def result(self) -> Any:
        if self._fn is not None:
            self._value, self._fn = self._fn(), None
        return self._value


@dataclass(frozen=True)
class Section:
    """One part of the report: ``sections/<template>.j2`` filled with ``data(ctx)``."""

    template: str
    title: str
    data: Callable[[ReportContext], dict[str, Any] | None]


_INLINE = re.compile(r"\*\*(.+?)\*\*|`([^`]+)`|\[([^\]]+)\]\(([^)\s]+)\)"
                     r"|(?<![\w*])\*([^*\s](?:[^*]*[^*\s])?)\*(?![\w*])")


def inline_html(text: Any) -> str:
    """Inline Markdown (**bold**, *emphasis*, `code`, [text](url)) to escaped HTML."""
    out, pos, s = [], 0, str(text)
    for m in _INLINE.finditer(s):
        out.append(html.escape(s[pos:m.start()]))
        if m.group(1) is not None:
            out.append(f"<b>{inline_html(m.group(1))}</b>")
        elif m.group(2) is not None:
            out.append(f"<code>{html.escape(m.group(2))}</code>")
        elif m.group(3) is not None:
            out.append(f'<a href="{html.escape(m.group(4))}">{inline_html(m.group(3))}</a>')
        else:
            out.append(f"<em>{inline_html(m.group(5))}</em>")
        pos = m.end()
    out.append(html.escape(s[pos:]))
    return "".join(out)


def _md_cell(cell: Cell | str, marks: bool) -> str:
    c = cell if isinstance(cell, Cell) else Cell(str(cell))
    text = c.text.replace("|", "\\|").replace("\n", " ")
    if marks and c.band in MARKS:
        text = f"{MARKS[c.band]} {text}"
    return text


def _html_cell(cell: Cell | str, label: bool) -> str:
    c = cell if isinstance(cell, Cell) else Cell(str(cell))
    classes = [c.band] if c.band else []
    if c.wrap:
        classes.append("wrap")
    elif label:
        classes.append("l")
    attrs = f' class="{" ".join(classes)}"' if classes else ""
    if c.title:
        attrs += f' title="{html.escape(c.title)}"'
    return f"<td{attrs}>{inline_html(c.text)}</td>"


def slug(text: str) -> str:
    """GitHub's heading anchor: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", text.lower()).replace(" ", "-")


class _Toc:
    """Collects the headings of one rendering pass and gives them unique anchors."""

    def __init__(self) -> None:
        self.entries: list[dict[str, Any]] = []
        self._seen: dict[str, int] = {}

    def __call__(self, level: int, text: str) -> str:
        base = slug(text)
        n = self._seen.get(base, 0)
        self._seen[base] = n + 1
        anchor = base if n == 0 else f"{base}-{n}"
        self.entries.append({"level": level, "text": text, "id": anchor})
        return anchor


def environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("impactbench", "templates"),
        autoescape=False,  # the HTML macros escape explicitly; Markdown must not be escaped
        trim_blocks=True, lstrip_blocks=True, keep_trailing_newline=True,
        undefined=jinja2.StrictUndefined, extensions=["jinja2.ext.do"],
    )
    env.filters["inline"] = inline_html
    env.filters["md_cell"] = _md_cell
    env.filters["md_align"] = lambda a: "---" if a == "left" else "--:"
    env.filters["html_cell"] = _html_cell
    return env


def render_documents(ctx: ReportContext, sections: Sequence[Section], title: str,
                     intro: str) -> dict[str, str]:
    """Render every section with data into ``{"md": README text, "html": index.html text}``."""
    env = environment()
    filled = [(s, d) for s in sections if (d := s.data(ctx)) is not None]
    out = {}
    for fmt in ("md", "html"):
        toc = _Toc()
        env.globals["toc"] = toc
        macros = env.get_template(f"{fmt}.j2").make_module({"toc": toc})
        bodies = []
        for section, data in filled:
            head = str(macros.h(2, section.title))
            body = env.get_template(f"sections/{section.template}.j2").render(
                m=macros, data=data, ctx=ctx, fmt=fmt)
            bodies.append(head + body)
        page = env.get_template(f"page.{fmt}.j2").render(
            title=title, intro=intro, toc=toc.entries, bodies=bodies)
        out[fmt] = re.sub(r"\n{3,}", "\n\n", page) if fmt == "md" else page
    return out


ROUND_OFF = 1e-9
"""A relative error smaller than this is floating-point round-off: printed as 0."""


def format_error(err: float, *, signed: bool = True) -> str:
    """A relative error in percent, as a plain number (never an exponent): two significant
    digits below 10 %, whole percent above (+0.000046 %, −1.2 %, −25 %, +100 %, +130 %);
    |err| below :data:`ROUND_OFF` is 0 %. ``signed=False``: a magnitude (1.2 %). Not a
    number (nothing compared): ``n/a``."""
    if math.isnan(err):
        return "n/a"
    if abs(err) < ROUND_OFF:
        return "0 %"
    pct = 100.0 * (err if signed else abs(err))
    if math.isinf(pct):
        text = f"{pct:+}"
    elif abs(pct) >= 9.95:  # two significant digits would round to 10 or more
        text = f"{pct:+.0f}"
    else:
        text = np.format_float_positional(pct, precision=2, unique=False, fractional=False,
                                          trim="-", sign=True)
    text = text if signed else text.lstrip("+")
    return f"{text} %".replace("-", "−")
