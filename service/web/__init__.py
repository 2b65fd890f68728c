"""Static files of the explorer page (`GET /`): index.html, explorer.js, explorer.css, favicon.

Plain HTML, CSS and JavaScript with no build step; served by `service.api.routes.pages`.
"""
