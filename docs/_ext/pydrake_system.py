"""The ``.. pydrake_system::`` directive: a System's ports drawn as a block diagram.

Drake's bindings document each System with a YAML block naming the System and its ports::

    .. pydrake_system::

        name: FuzzyDepthEstimator
        input_ports:
        - depth
        output_ports:
        - h_hat
        - z_hat

Drake renders it with a helper that is not part of the wheel; this extension draws the
same picture: the System's name in a box, its inputs as arrows into the box on the left,
its outputs as arrows out of it on the right. HTML builders get an inline SVG; every other
builder (text, LaTeX, man, ...) gets the same diagram as ASCII art in a literal block.

A port may carry a note in parentheses after its name (``noise (optional)``,
``depth (water on)``); the note is drawn smaller and grey. Port names are text, never
HTML. A malformed block (invalid YAML, no ``name``, a port that is not a string or a
number, an unknown key) is an error at the directive's line.
"""

from __future__ import annotations

import html

import yaml
from docutils import nodes
from sphinx.transforms.post_transforms import SphinxPostTransform
from sphinx.util.docutils import SphinxDirective

KEYS = ("name", "input_ports", "output_ports")


# Lower case, as docutils names its node classes.
class pydrake_system(nodes.General, nodes.Element):
    """The parsed block: attributes ``name``, ``input_ports``, ``output_ports``."""


def parse_system_yaml(text: str) -> tuple[str, list[str], list[str]]:
    """The System's name and its input and output port labels from the block's YAML.

    Raises:
        ValueError: saying what is wrong with the block.
    """
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ValueError(f"invalid YAML: {error}") from None
    if not isinstance(data, dict):
        raise ValueError("expected a mapping with 'name', 'input_ports' and 'output_ports'")
    unknown = sorted(str(key) for key in data if key not in KEYS)
    if unknown:
        raise ValueError(f"unknown key(s) {unknown}; allowed: {list(KEYS)}")
    name = data.get("name")
    if not isinstance(name, str) or not name.strip():
        raise ValueError("'name' must be a non-empty string")
    ports = []
    for key in ("input_ports", "output_ports"):
        value = data.get(key) or []
        if not isinstance(value, list):
            raise ValueError(f"'{key}' must be a list of port names")
        labels = []
        for item in value:
            if isinstance(item, bool) or not isinstance(item, (str, int, float)):
                raise ValueError(f"'{key}': a port must be a name, got {item!r}")
            labels.append(str(item).strip())
        ports.append(labels)
    return name.strip(), ports[0], ports[1]


def split_label(label: str) -> tuple[str, str]:
    """A port label as (name, note): ``"noise (optional)"`` -> ``("noise", "(optional)")``."""
    if label.endswith(")") and " (" in label:
        i = label.index(" (")
        return label[:i].rstrip(), label[i + 1 :]
    return label, ""


# --- the SVG picture ----------------------------------------------------------------------

FONT = 14.0  # px, port names and the System's name
NOTE_FONT = 11.0  # px, the notes in parentheses
CHAR = 0.6  # a monospace glyph's advance, in em
ROW = 24.0  # px between ports
ARROW = 30.0  # px, the arrows' length
GAP = 6.0  # px between a label and its arrow
PAD = 4.0


def _label_width(label: str) -> float:
    name, note = split_label(label)
    width = len(name) * CHAR * FONT
    if note:
        width += (1 + len(note)) * CHAR * NOTE_FONT
    return width


def _label_svg(label: str, x: float, y: float, anchor: str, side: str) -> str:
    name, note = split_label(label)
    esc = html.escape
    parts = [f'<tspan class="pydrake-port-name">{esc(name)}</tspan>']
    if note:
        parts.append(
            f'<tspan class="pydrake-port-note" font-size="{NOTE_FONT:g}" '
            f'fill="#666"> {esc(note)}</tspan>'
        )
    return (
        f'<text class="pydrake-port pydrake-{side}" data-port="{esc(name, quote=True)}" '
        f'x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}" dominant-baseline="middle">'
        + "".join(parts)
        + "</text>"
    )


def _arrow_svg(x0: float, x1: float, y: float) -> str:
    """A horizontal arrow from x0 to x1 (x1 > x0) with its head at x1."""
    return (
        f'<line x1="{x0:.1f}" y1="{y:.1f}" x2="{x1 - 7:.1f}" y2="{y:.1f}" '
        f'stroke="#333" stroke-width="1.5"/>'
        f'<polygon points="{x1:.1f},{y:.1f} {x1 - 8:.1f},{y - 4:.1f} '
        f'{x1 - 8:.1f},{y + 4:.1f}" fill="#333"/>'
    )


def _rows_y(count: int, top: float, height: float) -> list[float]:
    return [top + height * (i + 0.5) / count for i in range(count)]


def render_svg(name: str, inputs: list[str], outputs: list[str]) -> str:
    """The block diagram as an HTML fragment: a ``<div class="pydrake-system">`` holding
    an inline SVG (sized from the labels' lengths, drawn in a monospace font)."""
    esc = html.escape
    rows = max(len(inputs), len(outputs), 1)
    box_h = max(rows * ROW + 16.0, 48.0)
    box_w = max(len(name) * CHAR * FONT + 40.0, 120.0)
    left = max((_label_width(p) for p in inputs), default=0.0)
    right = max((_label_width(p) for p in outputs), default=0.0)
    in_w = left + GAP + ARROW if inputs else 0.0
    out_w = right + GAP + ARROW if outputs else 0.0
    box_x = PAD + in_w
    top = PAD
    width = box_x + box_w + out_w + PAD
    height = box_h + 2 * PAD
    body = [
        f'<rect x="{box_x:.1f}" y="{top:.1f}" width="{box_w:.1f}" height="{box_h:.1f}" '
        f'fill="#f0f0f0" stroke="#333" stroke-width="1.5"/>',
        f'<text class="pydrake-system-name" x="{box_x + box_w / 2:.1f}" '
        f'y="{top + box_h / 2:.1f}" text-anchor="middle" dominant-baseline="middle" '
        f'font-weight="bold">{esc(name)}</text>',
    ]
    for label, y in zip(inputs, _rows_y(len(inputs), top, box_h)):
        body.append(_arrow_svg(box_x - ARROW, box_x, y))
        body.append(_label_svg(label, box_x - ARROW - GAP, y, "end", "input"))
    for label, y in zip(outputs, _rows_y(len(outputs), top, box_h)):
        x = box_x + box_w
        body.append(_arrow_svg(x, x + ARROW, y))
        body.append(_label_svg(label, x + ARROW + GAP, y, "start", "output"))
    title = f"{name}: inputs {', '.join(inputs) or 'none'}; outputs {', '.join(outputs) or 'none'}"
    return (
        f'<div class="pydrake-system" data-system="{esc(name, quote=True)}" '
        f'style="margin: 1em 0; overflow-x: auto">'
        f'<svg xmlns="http://www.w3.org/2000/svg" role="img" width="{width:.0f}" '
        f'style="max-width: 100%; height: auto" '
        f'height="{height:.0f}" viewBox="0 0 {width:.1f} {height:.1f}" '
        f'font-family="DejaVu Sans Mono, Menlo, Consolas, monospace" font-size="{FONT:g}">'
        f"<title>{esc(title)}</title>" + "".join(body) + "</svg></div>"
    )


# --- the text picture ---------------------------------------------------------------------


def render_text(name: str, inputs: list[str], outputs: list[str]) -> str:
    """The block diagram as ASCII art, e.g.::

            +---------------------+
    depth ->|                     |-> h_hat
            | FuzzyDepthEstimator |
            |                     |-> z_hat
            +---------------------+
    """
    # One port every other row, so the name's row sits between ports when it can.
    rows = max(2 * max(len(inputs), len(outputs), 1) - 1, 1)

    def spread(labels):
        slots = [""] * rows
        for i, label in enumerate(labels):
            k = len(labels)
            slots[rows // 2 if k == 1 else round(i * (rows - 1) / (k - 1))] = label
        return slots

    ins, outs = spread(inputs), spread(outputs)
    left = max((len(p) for p in inputs), default=0)
    inner = len(name) + 2
    pad = " " * (left + 3 if inputs else 0)
    lines = [f"{pad}+{'-' * inner}+"]
    for i in range(rows):
        text = f" {name} " if i == rows // 2 else " " * inner
        into = f"{ins[i]:>{left}} ->" if ins[i] else " " * len(pad)
        out = f"-> {outs[i]}" if outs[i] else ""
        lines.append(f"{into}|{text}|{out}".rstrip())
    lines.append(f"{pad}+{'-' * inner}+")
    return "\n".join(lines)


# --- Sphinx -------------------------------------------------------------------------------


class PydrakeSystemDirective(SphinxDirective):
    """``.. pydrake_system::`` with the YAML block as its content."""

    has_content = True

    def run(self):
        try:
            name, inputs, outputs = parse_system_yaml("\n".join(self.content))
        except ValueError as error:
            raise self.error(f"pydrake_system: {error}") from None
        node = pydrake_system(name=name, input_ports=inputs, output_ports=outputs)
        self.set_source_info(node)
        return [node]


class RenderPydrakeSystems(SphinxPostTransform):
    """Replaces each parsed block with the picture the builder can show."""

    default_priority = 200

    def run(self, **kwargs):
        is_html = getattr(self.app.builder, "format", "") == "html"
        for node in list(self.document.findall(pydrake_system)):
            args = (node["name"], list(node["input_ports"]), list(node["output_ports"]))
            if is_html:
                new = nodes.raw("", render_svg(*args), format="html")
            else:
                text = render_text(*args)
                new = nodes.literal_block(text, text)
            new.source, new.line = node.source, node.line
            node.replace_self(new)


def setup(app):
    app.add_node(pydrake_system)
    app.add_directive("pydrake_system", PydrakeSystemDirective)
    app.add_post_transform(RenderPydrakeSystems)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
