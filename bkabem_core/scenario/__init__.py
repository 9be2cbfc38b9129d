"""bkabem_core/scenario"""
