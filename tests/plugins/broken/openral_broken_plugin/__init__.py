raise ImportError("the vendor SDK this plug-in needs is not installed")
