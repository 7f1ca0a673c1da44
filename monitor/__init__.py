"""The observation side: channel frames, stream readers and the built-in SPI metrics."""
