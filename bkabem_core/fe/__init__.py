"""bkabem_core/fe"""
