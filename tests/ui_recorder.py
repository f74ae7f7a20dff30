"""Call a panel's or preference's ``draw()`` in background Blender, where no real ``UILayout`` can be made.

``RecordingLayout`` stands in for ``UILayout`` and is strict where the real one is: every method it accepts
is a real ``UILayout`` function and every keyword a real parameter of it (read from ``bpy.types.UILayout``'s
RNA), icons must be real icon names, ``prop(data, name)`` must name a real property of ``data``, and
``operator(idname)`` must name a registered operator whose returned properties accept only real operator
properties. It records what was drawn so that tests can assert on labels, props and operators.

Use it only inside a process that has imported bpy (e.g. in ``run_py`` code).
"""
from __future__ import annotations

import bpy

_FUNCS = bpy.types.UILayout.bl_rna.functions
_LAYOUT_PROPS = set(bpy.types.UILayout.bl_rna.properties.keys())
ICONS = set(_FUNCS["label"].parameters["icon"].enum_items.keys())
_CONTAINERS = {"box", "row", "column", "split", "column_flow", "grid_flow", "panel_prop"}


class DrawError(AssertionError):
    pass


class _OpProps:
    def __init__(self, idname: str, props: set[str]):
        object.__setattr__(self, "_idname", idname)
        object.__setattr__(self, "_props", props)
        object.__setattr__(self, "values", {})

    def __setattr__(self, k, v):
        if k not in self._props:
            raise DrawError(f"operator {self._idname} has no property {k!r}")
        self.values[k] = v


class RecordingLayout:
    def __init__(self, log: list | None = None, parent: "RecordingLayout | None" = None):
        object.__setattr__(self, "log", [] if log is None else log)
        object.__setattr__(self, "parent", parent)
        object.__setattr__(self, "attrs", {})

    def __setattr__(self, k, v):
        if k not in _LAYOUT_PROPS:
            raise DrawError(f"UILayout has no attribute {k!r}")
        self.attrs[k] = v

    def enabled_here(self) -> bool:
        node = self
        while node is not None:
            if node.attrs.get("enabled", True) is False:
                return False
            node = node.parent
        return True

    def __getattr__(self, fn):
        if fn.startswith("_") or fn not in _FUNCS:
            raise DrawError(f"UILayout has no function {fn!r}")
        params = set(_FUNCS[fn].parameters.keys())

        def call(*args, **kw):
            bad = set(kw) - params
            if bad:
                raise DrawError(f"UILayout.{fn}() got unknown keyword(s) {sorted(bad)}")
            icon = kw.get("icon")
            if icon is not None and icon not in ICONS:
                raise DrawError(f"UILayout.{fn}(): unknown icon {icon!r}")
            if fn == "prop":
                data, name = args[0], args[1]
                if name not in data.bl_rna.properties:
                    raise DrawError(f"prop(): {type(data).__name__} has no property {name!r}")
            entry = {"fn": fn, "args": [a for a in args if isinstance(a, (str, int, float))], "kw": kw,
                     "enabled": self.enabled_here()}
            self.log.append(entry)
            if fn in _CONTAINERS:
                return RecordingLayout(self.log, self)
            if fn == "operator":
                idname = args[0] if args else kw["operator"]
                mod, _, name = idname.partition(".")
                if name not in dir(getattr(bpy.ops, mod)):
                    raise DrawError(f"operator(): {idname!r} is not a registered operator")
                rna = getattr(getattr(bpy.ops, mod), name).get_rna_type()
                return _OpProps(idname, set(rna.properties.keys()))
            return None

        return call

    # --- queries for tests ---
    def labels(self) -> list[str]:
        return [e["kw"].get("text", e["args"][0] if e["args"] else "") for e in self.log if e["fn"] == "label"]

    def operators(self) -> list[tuple[str, bool]]:
        return [((e["args"] or [e["kw"].get("operator")])[0], e["enabled"]) for e in self.log if e["fn"] == "operator"]

    def props(self) -> list[str]:
        return [e["args"][0] for e in self.log if e["fn"] == "prop"]


class _Self:
    """The ``self`` a draw function gets: ``layout`` is the recorder, everything else the real instance, or
    without one the class's attributes and methods (as a real panel instance has them)."""

    def __init__(self, layout, real=None, cls=None):
        object.__setattr__(self, "layout", layout)
        object.__setattr__(self, "_real", real)
        object.__setattr__(self, "_cls", cls)

    def __getattr__(self, k):
        if self._real is not None:
            return getattr(self._real, k)
        if self._cls is not None and hasattr(self._cls, k):
            import inspect
            raw = inspect.getattr_static(self._cls, k)
            if inspect.isfunction(raw):  # a method: bound to this stand-in
                return raw.__get__(self)
            return getattr(self._cls, k)  # data, staticmethod, classmethod: as the class gives them
        raise AttributeError(k)


def draw(cls, real=None, context=None) -> RecordingLayout:
    """Run ``cls.draw`` with a RecordingLayout; ``real`` is the instance whose properties draw() shows."""
    layout = RecordingLayout()
    cls.draw(_Self(layout, real, cls), context or bpy.context)
    return layout
