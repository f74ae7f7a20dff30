"""ssgi_addon/blender."""
