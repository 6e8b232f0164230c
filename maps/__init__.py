"""Shipped map files (the top-level maps/ folder, installed as package data)."""
