"""Reality against the model: the live graph read back (`discover`), compared (`drift`), recordings
judged (`recording`), and ROS 2 system_modes files (`smh`)."""
