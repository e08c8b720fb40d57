"""Placeholder until the dashboard lands: serves a page naming the project."""
import panel as pn

pn.pane.Markdown("# isl\nKalman–Bucy vs the ISL filter — the dashboard is being built.").servable(title="isl")
