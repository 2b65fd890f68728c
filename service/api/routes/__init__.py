"""The HTTP routes: dynamics (one per quantity), stream, robots, visuals, health, pages."""
