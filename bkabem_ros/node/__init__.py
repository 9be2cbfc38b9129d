"""bkabem_ros/node"""
