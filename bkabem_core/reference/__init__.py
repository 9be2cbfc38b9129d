"""bkabem_core/reference"""
