"""bkabem_core/embedded"""
