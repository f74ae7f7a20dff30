"""The learning half of SSGI. Never imports bpy: runs in plain Python, in a worker thread or elsewhere."""
