"""ssgi_addon/pipeline."""
