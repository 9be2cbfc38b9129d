"""bkabem_core/bearing"""
