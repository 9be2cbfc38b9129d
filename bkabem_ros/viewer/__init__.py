"""bkabem_ros/viewer"""
