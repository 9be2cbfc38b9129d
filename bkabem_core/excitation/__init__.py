"""bkabem_core/excitation"""
