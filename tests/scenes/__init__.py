"""Scene builders the tests share (bpy scripts run in the test's subprocess)."""
