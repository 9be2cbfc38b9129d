"""bkabem_core/embedded/datasets"""
