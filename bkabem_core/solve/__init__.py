"""bkabem_core/solve"""
