"""bkabem_ros/fleet"""
