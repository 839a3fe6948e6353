"""Coupler: participant protocol, mappings, time windows, acceleration and transports."""
