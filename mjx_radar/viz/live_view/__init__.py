"""The live view (``--live``): its state, page, HTML and HTTP server."""
