"""Scenario files, their loading and validation, the experiment protocol and the ``mrta`` CLI."""
