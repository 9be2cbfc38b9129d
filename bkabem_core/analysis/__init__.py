"""bkabem_core/analysis"""
