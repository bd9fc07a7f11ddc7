# SPDX-License-Identifier: Apache-2.0
"""Tracking-core building blocks: FHOG, KCF, DCF-CA, confidence measures, windows, frame conditioning."""
