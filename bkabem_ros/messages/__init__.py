"""bkabem_ros/messages"""
