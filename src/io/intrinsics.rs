//! Pinhole camera intrinsics from Open3D JSON or PCL grabber XML. (Being implemented; see issue 2.)
