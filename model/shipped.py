"""The models that ship with SSGI, by name: what the model menus list and what ``--model NAME`` accepts.

A model setting (the scene's, the node's, a command's ``--model``) holds a file path or one of these names; an
empty setting means ``default``. ``resolve`` turns a setting into the file to load.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

MODELS_DIR = Path(__file__).resolve().parents[1] / "models"


@dataclass(frozen=True)
class Shipped:
    name: str  # what a setting or --model holds
    file: str  # in models/
    label: str  # the menu's entry
    description: str  # the menu's tooltip: what a frame costs and when to pick it

    @property
    def path(self) -> Path:
        return MODELS_DIR / self.file


SHIPPED = (
    Shipped("default", "ssgi_default.pt", "Default",
            "The best light: each frame renders the passes the model reads (several EEVEE renders, and a short "
            "Cycles render of what emissive surfaces light), so it costs a few times EEVEE's own GI"),
    Shipped("one_render", "ssgi_one_render.pt", "One render",
            "About EEVEE's own cost: one EEVEE render a frame (ray tracing off) and the network; less accurate "
            "colour than Default where emitters or a sky light the room"),
)
BY_NAME = {m.name: m for m in SHIPPED}
DEFAULT = BY_NAME["default"]


def resolve(setting: str | None) -> Path | None:
    """The shipped model a setting names (``""`` or None: the default); None when it is a file path instead."""
    s = (setting or "").strip()
    if not s:
        return DEFAULT.path
    m = BY_NAME.get(s)
    return m.path if m is not None else None


def name_of(path) -> str | None:
    """The name of the shipped model at ``path`` (any spelling of the same file), else None."""
    try:
        p = Path(path).expanduser().resolve()
    except (OSError, RuntimeError, TypeError):
        return None
    return next((m.name for m in SHIPPED if m.path.resolve() == p), None)


# --- the model menu (the scene's and the node's): a view over a setting string and a "custom file" flag ---------------

CUSTOM = "CUSTOM"
INHERIT = "SCENE"  # the node's first entry: no model of its own, the scene's


def menu_items(inherit: bool = False) -> list[tuple[str, str, str]]:
    """(identifier, label, tooltip) of the model menu: [the scene's model,] each shipped model, a custom file."""
    items = [(INHERIT, "Scene's model", "The model chosen in Render Properties > SSGI")] if inherit else []
    items += [(m.name, m.label, m.description) for m in SHIPPED]
    items.append((CUSTOM, "Custom file...", "A checkpoint (.pt) or ONNX export (.onnx) of your own, such as one "
                                            "Fit to Scene made"))
    return items


def menu_choice(setting: str | None, custom: bool, inherit: bool = False) -> str:
    """The menu entry a stored setting shows: a file path (or the custom flag) is CUSTOM, a shipped name is itself,
    an empty setting is the default model (or, for the node, the scene's)."""
    s = (setting or "").strip()
    if custom or (s and s not in BY_NAME):
        return CUSTOM
    return s or (INHERIT if inherit else DEFAULT.name)


def setting_for(choice: str, setting: str | None, inherit: bool = False) -> tuple[str, bool]:
    """(setting, custom flag) to store for a menu entry: a shipped name (the scene's default: empty), empty for the
    node's INHERIT, and for CUSTOM the file path kept (a shipped name cleared: the file field starts empty)."""
    s = (setting or "").strip()
    if choice == CUSTOM:
        return ("" if s in BY_NAME else (setting or ""), True)
    if choice == INHERIT or (choice == DEFAULT.name and not inherit):
        return ("", False)
    return (choice, False)
