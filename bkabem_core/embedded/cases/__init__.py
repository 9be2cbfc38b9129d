"""bkabem_core/embedded/cases"""
