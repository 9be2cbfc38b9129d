"""bkabem_core/model"""
