"""bkabem_core/embedded/scenarios"""
