"""The aaai command line (installed as the import package aaai_cli)."""
