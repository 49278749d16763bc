"""Generated codec modules (codecgen output). Never edited by hand: run `codecgen build`."""
