"""ssgi_addon/runtime."""
