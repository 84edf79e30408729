"""Self-contained HTML pages: figures are embedded as base64 PNG, so a page opens offline."""

from __future__ import annotations

import base64
import html
import io
import os
from pathlib import Path

from tendon_id.atomic import write_text_atomic

_STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;max-width:1100px;\
margin:2em auto;padding:0 1em;color:#1d2330}
h1{font-size:1.6em;margin-bottom:.2em} h2{font-size:1.25em;margin-top:1.6em;border-bottom:1px solid #dde}
table{border-collapse:collapse;margin:.6em 0} td,th{border:1px solid #ccd;padding:.25em .6em;text-align:right}
th{background:#f2f4f8} td:first-child,th:first-child{text-align:left}
figure{margin:1em 0} figcaption{color:#555;font-size:.9em} img{max-width:100%}
.note{color:#555;font-size:.9em}
.warning{color:#8a1c00;background:#fff1ec;border-left:4px solid #d9480f;padding:.4em .7em}
"""


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


class HtmlPage:
    """Builds a single self-contained HTML page section by section."""

    def __init__(self, title: str):
        self.title = title
        self._parts: list[str] = []

    def heading(self, text: str, level: int = 2) -> None:
        self._parts.append(f"<h{level}>{html.escape(text)}</h{level}>")

    def paragraph(self, text: str, cls: str | None = None) -> None:
        c = f' class="{cls}"' if cls else ""
        self._parts.append(f"<p{c}>{html.escape(text)}</p>")

    def link(self, text: str, href: str, before: str = "", after: str = "") -> None:
        """A paragraph with one link (a relative ``href`` keeps a report folder movable)."""
        self._parts.append(
            f'<p>{html.escape(before)}<a href="{html.escape(href, quote=True)}">{html.escape(text)}</a>'
            f"{html.escape(after)}</p>"
        )

    def table(self, header: list[str], rows: list[list[object]]) -> None:
        head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
        body = "".join("<tr>" + "".join(f"<td>{html.escape(_fmt(v))}</td>" for v in row) + "</tr>" for row in rows)
        self._parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")

    def figure(self, fig, caption: str) -> None:
        data = figure_to_base64(fig)
        self._parts.append(
            f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}"/>'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )

    def render(self) -> str:
        return (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{html.escape(self.title)}</title><style>{_STYLE}</style></head><body>"
            f"<h1>{html.escape(self.title)}</h1>" + "\n".join(self._parts) + "</body></html>\n"
        )

    def write(self, path: str | os.PathLike) -> Path:
        """Write the page atomically (a temp file in the same folder, then rename)."""
        return write_text_atomic(path, self.render())


def _fmt(v: object) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)
