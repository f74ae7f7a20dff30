"""torch detection in the venv (bpy-free). The no-torch, installer and extension cases are
tests/blender/test_deps.py."""


def test_torch_detected_when_present():
    import torch

    from ssgi.ssgi_addon.runtime import deps
    ok, info = deps.torch_status(refresh=True)
    assert ok and info == str(torch.__version__)
    assert deps.torch_available()
