"""Thin Operator classes: parse the user's intent, call ssgi_addon / model, report."""
