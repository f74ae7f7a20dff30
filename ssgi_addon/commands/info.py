"""`cli.py info`: versions, torch and onnxruntime availability and the channel spec."""
from __future__ import annotations

import platform
import sys


def run(args) -> dict:
    import numpy

    try:
        import bpy
        blender, blender_error = bpy.app.version_string, None
    except ImportError as e:  # a training node: no Blender (train, export, predict and the dataset tools need none)
        blender, blender_error = None, f"{type(e).__name__}: {e}"

    from ...model import channels
    from ..runtime import deps
    ok, torch_info = deps.torch_status()
    ort_ok, ort_info = deps.onnxruntime_status()
    out = {
        "blender": blender,
        "blender_error": blender_error,
        "python": sys.version.split()[0],
        "numpy": numpy.__version__,
        "torch": torch_info if ok else None,
        "torch_error": None if ok else torch_info,
        "onnxruntime": ort_info if ort_ok else None,
        "onnxruntime_error": None if ort_ok else ort_info,
        "platform": platform.platform(),
        "channel_spec_version": channels.FORMAT_VERSION,
        "default_inputs": channels.format_spec(channels.DEFAULT_INPUTS),
    }
    for k, v in out.items():
        print(f"{k}: {v}", file=sys.stderr)
    return out


def register_cli(sub) -> None:
    p = sub.add_parser("info", help="print versions, torch availability and the channel spec",
                       description="Print Blender, Python, numpy and torch versions and the channel spec.")
    p.set_defaults(func=run)
