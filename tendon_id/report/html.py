"""Self-contained HTML pages, rendered with Jinja2 from one base layout (``templates/base.html.j2``).

Figures are embedded as base64 PNG and the style is inline, so a page opens offline and has no
script. A page is built section by section; what the reader must know first (the verdict, how far
to trust it, the simulator's truth beside the finding, any warning that changes how the numbers
read) goes into :meth:`HtmlPage.lead`, which the layout places under the title whatever the order
of the calls.
"""

from __future__ import annotations

import base64
import io
import os
import re
from functools import lru_cache
from pathlib import Path

from tendon_id.atomic import write_text_atomic

#: Classes a lead sentence may take: the finding, the simulator's truth beside it, a warning, context.
LEAD_TONES = ("verdict", "truth", "warning", "plain")


def pyplot():
    """``matplotlib.pyplot`` on the headless Agg backend (reports are drawn without a display).

    Imported on first use, not at module level: choosing a backend is process-wide, and a user
    who imports tendon-id in an interactive session keeps theirs until a report is drawn.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_to_base64(fig) -> str:
    """PNG bytes of a matplotlib figure as base64 text; closes the figure."""
    import matplotlib.pyplot as plt  # see pyplot(): on use

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


@lru_cache(maxsize=1)
def _environment():
    # Jinja2 is torch's dependency too, so it is always installed; imported on first render.
    import jinja2

    return jinja2.Environment(
        loader=jinja2.PackageLoader("tendon_id.report", "templates"),
        autoescape=True,  # every value is text, never markup
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        undefined=jinja2.StrictUndefined,
    )


def _version() -> str:
    # From the installed distribution, not ``tendon_id.__version__``: the foundation imports no package face.
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("tendon-id")
    except PackageNotFoundError:  # a checkout on sys.path without an install
        return "(not installed)"


class HtmlPage:
    """A single self-contained HTML page, built section by section.

    Parameters
    ----------
    title : str
        The page's title (``<title>`` and ``<h1>``).
    subtitle : str, optional
        One line under the title: what the page is about (the data, the model).
    made_by : str, optional
        The command that made the page, in its footer.
    contents : bool
        A line of links to the page's second-level headings under the lead.
    """

    def __init__(self, title: str, subtitle: str | None = None, made_by: str | None = None, contents: bool = False):
        self.title = title
        self.subtitle = subtitle
        self.made_by = made_by
        self.contents = contents
        self._lead: list[dict] = []
        self._sections: list[dict] = []

    def lead(self, text: str, tone: str = "plain") -> None:
        """A sentence for the box under the title: what the reader must know before any number.

        Parameters
        ----------
        text : str
            One or two plain sentences.
        tone : {"verdict", "truth", "warning", "plain"}
            ``verdict``: the finding and how far to trust it; ``truth``: the simulator's truth
            beside it; ``warning``: something that changes how the numbers below read.
        """
        if tone not in LEAD_TONES:
            raise ValueError(f"tone must be one of {', '.join(LEAD_TONES)}, got {tone!r}")
        self._lead.append({"text": text, "cls": tone})

    @property
    def lead_text(self) -> list[str]:
        """The lead's sentences, in order (what the first screen says)."""
        return [s["text"] for s in self._lead]

    def heading(self, text: str, level: int = 2) -> None:
        anchor = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") if level == 2 else None
        self._sections.append({"kind": "heading", "text": text, "level": level, "anchor": anchor})

    def paragraph(self, text: str, cls: str | None = None) -> None:
        self._sections.append({"kind": "paragraph", "text": text, "cls": cls})

    def link(self, text: str, href: str, before: str = "", after: str = "") -> None:
        """A paragraph with one link (a relative ``href`` keeps a report folder movable)."""
        self._sections.append({"kind": "link", "text": text, "href": href, "before": before, "after": after})

    def table(
        self, header: list[str], rows: list[list[object]], caption: str | None = None, collapsed: str | None = None
    ) -> None:
        """A table; numbers show 4 significant digits.

        Parameters
        ----------
        caption : str, optional
            A line above the table.
        collapsed : str, optional
            Fold the table behind this summary line (a reference table the reader opens on demand).
        """
        self._sections.append(
            {
                "kind": "table",
                "header": [str(h) for h in header],
                "rows": [[_fmt(v) for v in row] for row in rows],
                "caption": caption,
                "collapsed": collapsed,
            }
        )

    def figure(self, fig, caption: str) -> None:
        self._sections.append({"kind": "figure", "data": figure_to_base64(fig), "caption": caption})

    def render(self) -> str:
        contents = [s for s in self._sections if s["kind"] == "heading" and s["anchor"]] if self.contents else []
        return (
            _environment()
            .get_template("page.html.j2")
            .render(
                title=self.title,
                subtitle=self.subtitle,
                made_by=self.made_by,
                version=_version(),
                lead=self._lead,
                sections=self._sections,
                contents=contents,
            )
        )

    def write(self, path: str | os.PathLike) -> Path:
        """Write the page atomically (a temp file in the same folder, then rename)."""
        return write_text_atomic(path, self.render())


def _fmt(v: object) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)
