"""Small building blocks for self-contained HTML pages."""

from __future__ import annotations

import base64
import html
import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

STYLE = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:14px}td,th{border:1px solid #ccc;padding:4px 6px;text-align:right}
th{background:#f3f3f3}.bad{color:#b00}.good{color:#070}figure{display:inline-block;margin:0 1em 1em 0;max-width:100%}
img{max-width:100%;height:auto}pre{white-space:pre-wrap;overflow-wrap:anywhere}
.headline{font-size:17px;line-height:1.45}summary{cursor:pointer;font-weight:600;margin:1em 0}"""


def image_tag(data: bytes, mime: str, caption: str) -> str:
    """An inline image (``mime``: png, gif) with its caption."""
    encoded = base64.b64encode(data).decode()
    return (f'<figure><img alt="{html.escape(caption)}" src="data:image/{mime};base64,{encoded}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def figure_tag(fig, caption: str) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return image_tag(buf.getvalue(), "png", caption)


def in_words(name: str) -> str:
    """An identifier (an effect's or a law's name) with spaces: floor_friction, floor friction."""
    return name.replace("_", " ")


def link_tag(href: str, text: str) -> str:
    return f"<a href='{html.escape(href)}'>{html.escape(text)}</a>"


def table_tag(header: list[str], rows: list[list[str]], row_classes: list[str] | None = None) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = []
    for i, row in enumerate(rows):
        cls = f' class="{row_classes[i]}"' if row_classes and row_classes[i] else ""
        body.append(f"<tr{cls}>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def page(title: str, body: str) -> str:
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{STYLE}</style></head><body><h1>{html.escape(title)}</h1>{body}</body></html>\n")
