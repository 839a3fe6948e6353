"""Scenario files: TOML, validated by one pydantic schema shared by every participant."""
