"""The Blender half of SSGI (imports bpy): scene randomizer, pass setup, bake, compositor node, properties,
preferences and the main-thread job pump. Thin glue over model/."""


def root_package() -> str:
    """The extension's top-level package name: ``ssgi`` from a checkout, ``bl_ext.<repo>.ssgi`` when installed."""
    return __package__.rsplit(".", 1)[0]
