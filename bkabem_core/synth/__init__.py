"""bkabem_core/synth"""
