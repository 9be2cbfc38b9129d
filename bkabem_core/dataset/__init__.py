"""bkabem_core/dataset"""
