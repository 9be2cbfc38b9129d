"""bkabem_ros/recording"""
