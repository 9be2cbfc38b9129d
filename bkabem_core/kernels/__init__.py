"""bkabem_core/kernels"""
