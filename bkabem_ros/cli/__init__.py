"""bkabem_ros/cli"""
