"""The aaai command line (installed as the import package aaai_cli).

Importing it asks MKL for the same matrix products on every CPU (aaai.numerics) before any command
computes anything, so that training and scoring with the same config and seed give the same bits
on any x86-64 machine.
"""

from aaai.numerics import portable_maths

portable_maths()
